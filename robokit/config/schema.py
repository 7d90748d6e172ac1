"""pydantic config schemas for plugin types: :class:`Schema` and the validation that turns pydantic's errors into
one-line :class:`~robokit.errors.ConfigError`\\ s.

Imported only when a plugin type with a pydantic schema is used (its module does ``from robokit.config import
Schema``, which lands here), or by commands that load every plugin: a run whose config uses only the core
sections and light schemas (:mod:`robokit.config.sections`) never imports pydantic. ``robokit.config`` re-exports
everything public here.
"""

from __future__ import annotations

import typing
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, GetCoreSchemaHandler, ValidationError
from pydantic_core import CoreSchema

from robokit.config import sections
from robokit.config.sections import FLOAT_LIMIT, error_from_parts
from robokit.errors import ConfigError


def _field(alias: Any) -> Any:
    """The bounds of a unit type of :mod:`robokit.config.sections` (``Annotated[float, Bounds(...)]``) as a pydantic
    ``Field``: each unit's bounds are defined once, for both kinds of schema."""
    bounds = typing.get_args(alias)[1]
    limits = {k: getattr(bounds, k) for k in ("ge", "gt", "le", "lt") if getattr(bounds, k) is not None}
    return Field(**limits, description=bounds.description or None)


Coord = Annotated[float, _field(sections.Coord)]
"""A position coordinate in metres: within ±10 km of the origin."""
Angle = Annotated[float, _field(sections.Angle)]
Unit = Annotated[float, _field(sections.Unit)]
Length = Annotated[float, _field(sections.Length)]
Position = tuple[Coord, Coord, Coord]
Gravity = Annotated[float, _field(sections.Gravity)]
Newtons = Annotated[float, _field(sections.Newtons)]

_STRICT_SCALARS = frozenset({"int", "float", "bool", "str"})


def _harden(node: Any, owner: type) -> None:
    """Make every scalar in a schema strict; floats finite and within ``±FLOAT_LIMIT`` by default.

    Strict scalars refuse ``true`` for a number, ``1`` or ``"no"`` for a bool and numbers for strings, while
    containers stay lax (a TOML array is accepted for a tuple) and an integer is still accepted for a float.
    Nested models are left alone: each :class:`Schema` subclass hardens its own fields.
    """
    if isinstance(node, dict):
        if node.get("type") == "model" and node.get("cls") is not owner:
            return
        kind = node.get("type")
        if isinstance(kind, str) and kind in _STRICT_SCALARS:
            node["strict"] = True
        if kind == "float":
            node["allow_inf_nan"] = False
            if "le" not in node and "lt" not in node:
                node["le"] = FLOAT_LIMIT
            if "ge" not in node and "gt" not in node:
                node["ge"] = -FLOAT_LIMIT
        for value in node.values():
            _harden(value, owner)
    elif isinstance(node, list):
        for value in node:
            _harden(value, owner)


class Schema(BaseModel):
    """Base of every pydantic config model: frozen, unknown keys rejected, strict types, finite numbers.

    Plugin schemas should subclass it; they inherit the rules: no bool for a number or a number for a bool, no
    string for a bool, every float finite and within ``±FLOAT_LIMIT`` unless the field declares its own bounds
    (declare physically meaningful ones with ``Field(ge=..., le=...)``). An integer is accepted for a float.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @classmethod
    # mutmut wraps every function it mutates in a trampoline, which pydantic cannot call as this hook: leave it whole
    def __get_pydantic_core_schema__(
        cls, source: Any, handler: GetCoreSchemaHandler
    ) -> CoreSchema:  # pragma: no mutate block
        schema = handler(source)
        _harden(schema, cls)
        return schema


def validation_error(exc: ValidationError, prefix: str = "") -> ConfigError:
    """Turn the first pydantic error into a one-line ConfigError at ``prefix.loc``."""
    err = exc.errors()[0]
    fields = getattr(exc, "_robokit_fields", None) or []
    return error_from_parts(tuple(err["loc"]), err["type"], str(err["msg"]), err.get("input"), prefix, fields)


def validate_pydantic(model: type[BaseModel], data: Any, key: str) -> Any:
    """Validate a mapping against a pydantic model; raise a one-line ConfigError placed at ``key``."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        fields = _nested_fields(model, exc)
        exc._robokit_fields = fields  # type: ignore[attr-defined]
        raise validation_error(exc, key) from None


def _nested_fields(model: type[BaseModel], exc: ValidationError) -> list[str]:
    """Field names of the (possibly nested) model an unknown-key error is about."""
    loc = exc.errors()[0]["loc"][:-1]
    current: Any = model
    for part in loc:
        field = getattr(current, "model_fields", {}).get(part)
        if field is None:
            return list(getattr(current, "model_fields", {}))
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            current = ann
    return list(getattr(current, "model_fields", {}))
