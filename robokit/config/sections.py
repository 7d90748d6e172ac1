"""Light config schemas: frozen dataclasses that robokit validates itself, without importing pydantic.

The core sections (``[world]``, ``[bodies.*]``, ``[[events]]``...) and the built-in ``local`` reporter are declared
this way, so that a run whose config uses no pydantic-schema plugin never pays pydantic's import (~75 ms). The rules
are those of :class:`robokit.config.Schema`: unknown keys refused, strict scalars (no ``true`` for a number, no
number for a bool or a string; an integer is accepted for a float), every float finite and within
``±FLOAT_LIMIT`` unless the field declares bounds, tuples from TOML arrays of the exact length, ``Literal`` choices,
optional fields, ``dict[str, ...]`` tables and nested sections. The error texts are pydantic's, so both kinds of
schema read the same to the user.

A plugin may register either kind of schema::

    class LocalReportConfig(Section):
        dir: str = setting("results", min_length=1, description="folder for result files")

        def check(self) -> None:  # optional: cross-field rules, raise ValueError("what is wrong")
            ...

Supported field types: ``bool``, ``int``, ``float``, ``str``, ``Literal[...]``, ``X | None``, ``tuple[X, Y]``,
``tuple[X, ...]``, ``dict[str, X]``, nested :class:`Section` subclasses and ``Any`` (taken as given), each
optionally ``Annotated[X, Bounds(...)]``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import types
import typing
from collections.abc import Callable, Mapping
from typing import Annotated, Any, ClassVar, Literal

from robokit.errors import ConfigError, did_you_mean

FLOAT_LIMIT = 1e9
"""Every float in a schema is finite and within ``±FLOAT_LIMIT`` unless its field says otherwise."""

Loc = tuple[Any, ...]
Check = Callable[[Any, Loc], Any]


class Bounds:
    """Constraints of a field (or, inside ``Annotated``, of a tuple item or table value): numbers within
    ``ge``/``gt``/``le``/``lt``, strings at least ``min_length`` long; ``description`` says the unit."""

    __slots__ = ("ge", "gt", "le", "lt", "min_length", "description")

    def __init__(self, ge: float | None = None, gt: float | None = None, le: float | None = None,
                 lt: float | None = None, min_length: int | None = None, description: str = "") -> None:
        self.ge, self.gt, self.le, self.lt, self.min_length, self.description = ge, gt, le, lt, min_length, description

    def over(self, base: Bounds) -> Bounds:
        """These bounds, completed by ``base`` where they say nothing."""
        mine = [getattr(self, k) for k in self.__slots__]
        return Bounds(*(getattr(base, k) if v is None or v == "" else v for k, v in zip(self.__slots__, mine,
                                                                                        strict=True)))

    def __repr__(self) -> str:
        shown = ", ".join(f"{k}={getattr(self, k)!r}" for k in self.__slots__ if getattr(self, k) not in (None, ""))
        return f"Bounds({shown})"


class _Setting:
    """What :func:`setting` declares about a field (kept on the class in ``_fields``)."""

    __slots__ = ("default", "factory", "bounds", "before")

    def __init__(self, default: Any, factory: Any, bounds: Bounds, before: Callable[[Any], Any] | None) -> None:
        self.default, self.factory, self.bounds, self.before = default, factory, bounds, before

    @property
    def required(self) -> bool:
        return self.default is _MISSING and self.factory is _MISSING


_MISSING: Any = dataclasses.MISSING


def setting(default: Any = _MISSING, *, default_factory: Callable[[], Any] | Any = _MISSING,
            ge: float | None = None, gt: float | None = None, le: float | None = None, lt: float | None = None,
            min_length: int | None = None, description: str = "",
            before: Callable[[Any], Any] | None = None) -> Any:
    """A field of a :class:`Section`: its default (none = required; ``default_factory`` for a fresh list or dict
    each time), bounds, description, and an optional ``before`` hook that sees the raw value first (raise
    ``ValueError`` to refuse it with your own message)."""
    return _Setting(default, default_factory, Bounds(ge, gt, le, lt, min_length, description), before)


class Invalid(Exception):
    """One validation problem, in pydantic's terms: where (``loc``), its ``kind`` (pydantic's error type), the
    message and the value found; ``fields`` lists the valid keys for an unknown one."""

    def __init__(self, loc: Loc, kind: str, msg: str, value: Any, fields: tuple[str, ...] = ()) -> None:
        super().__init__(msg)
        self.loc, self.kind, self.msg, self.value, self.fields = loc, kind, msg, value, fields


class Section:
    """Base of a light schema: subclass it and declare the fields as annotated class attributes, with a plain
    default or :func:`setting`; :meth:`check` holds the cross-field rules.

    Instances are frozen (assigning raises ``dataclasses.FrozenInstanceError``), compare and hash by value, and
    are built with keyword arguments (``LocalReportConfig(dir="out")``, not validated) or by :meth:`validate`.
    No ``@dataclass`` decorator: a class statement costs nothing here, while a dataclass compiles its methods.
    """

    _fields: ClassVar[dict[str, _Setting]] = {}
    _checks: ClassVar[dict[str, tuple[Check, Callable[[Any], Any] | None, bool]] | None] = None
    ignore_unknown: ClassVar[bool] = False
    """True: keys that are not fields are left for someone else (``[report]``'s reporter tables), not refused."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        fields = dict(cls._fields)  # the base's fields first, as dataclasses order them
        for name, annotation in cls.__dict__.get("__annotations__", {}).items():
            if isinstance(annotation, str) and annotation.split("[", 1)[0] in ("ClassVar", "typing.ClassVar"):
                continue
            if annotation is ClassVar or typing.get_origin(annotation) is ClassVar:
                continue
            value = cls.__dict__.get(name, _MISSING)
            spec = value if isinstance(value, _Setting) else _Setting(value, _MISSING, Bounds(), None)
            if isinstance(spec.default, (list, dict, set)):
                raise TypeError(f"{cls.__name__}.{name}: mutable default {spec.default!r}; use "
                                "setting(default_factory=...)")
            if spec.default is _MISSING:
                if name in cls.__dict__:
                    delattr(cls, name)
            else:
                setattr(cls, name, spec.default)
            fields[name] = spec
        cls._fields = fields
        cls._checks = None

    def __init__(self, **values: Any) -> None:
        cls = type(self)
        for name in values:
            if name not in cls._fields:
                raise TypeError(f"{cls.__name__}() got an unexpected keyword argument {name!r}")
        for name, spec in cls._fields.items():
            if name in values:
                value = values[name]
            elif spec.factory is not _MISSING:
                value = spec.factory()
            elif spec.default is not _MISSING:
                value = spec.default
            else:
                raise TypeError(f"{cls.__name__}() missing required keyword argument {name!r}")
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: Any) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot assign to field {name!r}")

    def __delattr__(self, name: str) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}")

    def _values(self) -> tuple[Any, ...]:
        return tuple(getattr(self, name) for name in self._fields)

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return self._values() == other._values()  # type: ignore[attr-defined]

    def __hash__(self) -> int:
        return hash((self.__class__, self._values()))

    def __repr__(self) -> str:
        shown = ", ".join(f"{name}={getattr(self, name)!r}" for name in self._fields)
        return f"{self.__class__.__qualname__}({shown})"

    def check(self) -> None:
        """Cross-field rules, run after every field is valid; raise ``ValueError`` with the problem."""

    @classmethod
    def validate(cls, data: Any, loc: Loc = ()) -> Any:
        """Validate a mapping (a TOML table) into a frozen instance.

        Raises:
            Invalid: The first problem, fields in declaration order, then unknown keys, then :meth:`check`.
        """
        if isinstance(data, cls):
            return data
        if not isinstance(data, Mapping):
            raise Invalid(loc, "model_type", f"Input should be a valid dictionary or instance of {cls.__name__}",
                          data)
        checks = cls._checks or _compile(cls)
        values = {}
        for name, (check, before, required) in checks.items():
            if name not in data:
                if required:
                    raise Invalid((*loc, name), "missing", "Field required", data)
                continue
            value = data[name]
            if before is not None:
                try:
                    value = before(value)
                except ValueError as exc:
                    raise Invalid((*loc, name), "value_error", f"Value error, {exc}", value) from None
            values[name] = check(value, (*loc, name))
        for key in () if cls.ignore_unknown else data:
            if key not in checks:
                raise Invalid((*loc, key), "extra_forbidden", "Extra inputs are not permitted", data[key],
                              tuple(checks))
        obj = cls(**values)
        try:
            obj.check()
        except ValueError as exc:
            raise Invalid(loc, "value_error", f"Value error, {exc}", data) from None
        return obj

    @classmethod
    def model_validate(cls, data: Any) -> Any:
        """pydantic's spelling of :meth:`validate`, for code written against either kind of schema.

        Raises:
            robokit.errors.ConfigError: One line naming the key and the problem.
        """
        if not isinstance(data, Mapping):
            raise ConfigError(f"expected a table, got {describe_value(data)}")
        try:
            return cls.validate(data)
        except Invalid as exc:
            raise error_from_parts(exc.loc, exc.kind, exc.msg, exc.value, "", exc.fields) from None


def field_names(cls: type) -> tuple[str, ...]:
    """The keys a schema accepts (a :class:`Section` or a pydantic model), in declaration order."""
    if isinstance(cls, type) and issubclass(cls, Section):
        return tuple(cls._fields)
    return tuple(getattr(cls, "model_fields", {}))


def _compile(cls: type[Section]) -> dict[str, tuple[Check, Callable[[Any], Any] | None, bool]]:
    """One checker per field of ``cls``, built from its type hints on first use and kept on the class."""
    hints = _field_types(cls)
    checks = {name: (_checker(hints[name], spec.bounds), spec.before, spec.required)
              for name, spec in cls._fields.items()}
    cls._checks = checks
    return checks


def _field_types(cls: type[Section]) -> dict[str, Any]:
    """The annotation of every field; a string annotation (``from __future__ import annotations``) is evaluated
    in its class's module (a module without that import spares this: its annotations are objects already)."""
    hints = {}
    for owner in reversed(cls.__mro__):
        for name, annotation in owner.__dict__.get("__annotations__", {}).items():
            if name not in cls._fields:
                continue
            if isinstance(annotation, str):
                namespace = vars(sys.modules[owner.__module__])
                try:
                    annotation = eval(annotation, namespace, dict(vars(owner)))  # noqa: S307 - the class's own code
                except NameError as exc:  # a name used in an annotation is not at module level
                    raise TypeError(f"robokit.config.sections: cannot resolve the field types of {cls.__qualname__}: "
                                    f"{exc}") from None
            hints[name] = annotation
    return hints


def _checker(tp: Any, bounds: Bounds) -> Check:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin is Annotated:
        for extra in tp.__metadata__:
            if isinstance(extra, Bounds):
                bounds = extra.over(bounds)
        return _checker(args[0], bounds)
    if origin in (typing.Union, types.UnionType) and type(None) in args:
        rest = [a for a in args if a is not type(None)]
        if len(rest) != 1:
            raise TypeError(f"robokit.config.sections: unsupported field type {tp!r} (one type or None)")
        inner = _checker(rest[0], bounds)
        return lambda value, loc: None if value is None else inner(value, loc)
    if origin is Literal:
        return _literal(args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return _tuple((), _checker(args[0], Bounds()))
        return _tuple(tuple(_checker(a, Bounds()) for a in args), None)
    if origin is dict:
        return _table(_checker(args[1], Bounds()))
    if isinstance(tp, type) and issubclass(tp, Section):
        return tp.validate
    if tp is Any:
        return lambda value, loc: value
    scalar = _SCALARS.get(tp)
    if scalar is None:
        raise TypeError(f"robokit.config.sections: unsupported field type {tp!r}")
    return scalar(bounds)


def _literal(choices: tuple[Any, ...]) -> Check:
    shown = [repr(c) for c in choices]
    expected = shown[0] if len(shown) == 1 else f"{', '.join(shown[:-1])} or {shown[-1]}"

    def check(value: Any, loc: Loc) -> Any:
        for choice in choices:  # a str subclass (numpy's) matches a string choice; otherwise the type must match
            if (isinstance(value, str) if isinstance(choice, str) else type(value) is type(choice)) and value == choice:
                return choice
        raise Invalid(loc, "literal_error", f"Input should be {expected}", value)

    return check


def _tuple(items: tuple[Check, ...], each: Check | None) -> Check:
    def check(value: Any, loc: Loc) -> Any:
        if isinstance(value, (list, tuple)):
            given = value
        elif isinstance(value, (str, bytes, bytearray, Mapping)) or not hasattr(value, "__iter__"):
            raise Invalid(loc, "tuple_type", "Input should be a valid tuple", value)
        else:  # like pydantic's lax tuples: any other iterable (a numpy array, a set, a generator) is read once
            given = list(value)
        if each is not None:
            return tuple(each(v, (*loc, i)) for i, v in enumerate(given))
        if len(given) > len(items):
            raise Invalid(loc, "too_long", f"Tuple should have at most {len(items)} item{'s' * (len(items) != 1)}"
                          f" after validation, not {len(given)}", value)
        out = tuple(c(v, (*loc, i)) for i, (c, v) in enumerate(zip(items, given, strict=False)))  # a short one: below
        if len(given) < len(items):
            raise Invalid((*loc, len(given)), "missing", "Field required", value)
        return out

    return check


def _table(each: Check) -> Check:
    def check(value: Any, loc: Loc) -> Any:
        if not isinstance(value, Mapping):
            raise Invalid(loc, "dict_type", "Input should be a valid dictionary", value)
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise Invalid((*loc, key, "[key]"), "string_type", "Input should be a valid string", key)
            out[key] = each(item, (*loc, key))
        return out

    return check


def _number(value: float) -> str:
    """A bound as pydantic shows it: ``1000000`` for ``1e6``, ``0.1`` for ``0.1``."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)


def _bounded(bounds: Bounds, default_limit: bool) -> Callable[[Any, Any, Loc], None]:
    ge, gt, le, lt = bounds.ge, bounds.gt, bounds.le, bounds.lt
    if default_limit:
        if le is None and lt is None:
            le = FLOAT_LIMIT
        if ge is None and gt is None:
            ge = -FLOAT_LIMIT

    def check(number: Any, value: Any, loc: Loc) -> None:
        if le is not None and not number <= le:
            raise Invalid(loc, "less_than_equal", f"Input should be less than or equal to {_number(le)}", value)
        if lt is not None and not number < lt:
            raise Invalid(loc, "less_than", f"Input should be less than {_number(lt)}", value)
        if ge is not None and not number >= ge:
            raise Invalid(loc, "greater_than_equal", f"Input should be greater than or equal to {_number(ge)}",
                          value)
        if gt is not None and not number > gt:
            raise Invalid(loc, "greater_than", f"Input should be greater than {_number(gt)}", value)

    return check


def _float(bounds: Bounds) -> Check:
    within = _bounded(bounds, default_limit=True)

    def check(value: Any, loc: Loc) -> Any:
        number: float
        if type(value) is float:
            number = value
        else:
            like = _float_like(value)
            if like is None:
                raise Invalid(loc, "float_type", "Input should be a valid number", value)
            number = like
        if not math.isfinite(number):
            raise Invalid(loc, "finite_number", "Input should be a finite number", value)
        within(number, value, loc)
        return number

    return check


def _float_like(value: Any) -> float | None:
    """A number (an int, a numpy scalar, a ``Decimal``...) as a float; None for a bool (numpy's too), a string,
    an int too large for a float, or anything ``float()`` refuses."""
    kind = type(value)
    if isinstance(value, (bool, str, bytes, bytearray)) or (kind.__module__ == "numpy" and kind.__name__ in
                                                            ("bool_", "bool")):
        return None
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return None


def _int(bounds: Bounds) -> Check:
    within = _bounded(bounds, default_limit=False)

    def check(value: Any, loc: Loc) -> Any:
        if isinstance(value, bool) or not isinstance(value, int):
            raise Invalid(loc, "int_type", "Input should be a valid integer", value)
        within(value, value, loc)
        return int(value)

    return check


def _bool(bounds: Bounds) -> Check:
    def check(value: Any, loc: Loc) -> Any:
        if not isinstance(value, bool):
            raise Invalid(loc, "bool_type", "Input should be a valid boolean", value)
        return value

    return check


def _str(bounds: Bounds) -> Check:
    least = bounds.min_length

    def check(value: Any, loc: Loc) -> Any:
        if not isinstance(value, str):
            raise Invalid(loc, "string_type", "Input should be a valid string", value)
        if least is not None and len(value) < least:
            raise Invalid(loc, "string_too_short",
                          f"String should have at least {least} character{'s' * (least != 1)}", value)
        return str(value)

    return check


_SCALARS: dict[Any, Callable[[Bounds], Check]] = {float: _float, int: _int, bool: _bool, str: _str}

# Field types of the core sections (robokit.config), in metres, degrees, newtons...
Coord = Annotated[float, Bounds(ge=-1e4, le=1e4, description="metres, world frame")]
"""A position coordinate in metres: within ±10 km of the origin."""
Angle = Annotated[float, Bounds(ge=-720.0, le=720.0, description="degrees")]
Unit = Annotated[float, Bounds(ge=0.0, le=1.0)]
Length = Annotated[float, Bounds(gt=0, le=1e3, description="metres")]
Position = tuple[Coord, Coord, Coord]
Gravity = Annotated[float, Bounds(ge=-1000.0, le=1000.0, description="m/s^2")]
Newtons = Annotated[float, Bounds(ge=-1e6, le=1e6, description="newtons")]


def describe_value(value: Any) -> str:
    """``repr(value)``, cut to 60 characters: how an error message shows what it found."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def error_from_parts(loc: tuple[Any, ...], kind: str, msg: str, value: Any, prefix: str = "",
                     fields: Any = ()) -> ConfigError:
    """One validation problem as a one-line ConfigError at ``prefix.loc``.

    ``kind`` and ``msg`` are in pydantic's terms (its error type and message), as both kinds of schema report them
    (:mod:`robokit.config.schema`, :mod:`robokit.config.sections`): an unknown key gets a "did you mean" and the valid
    keys (``fields``), a short array "too few values", and every type or bound error the value found.
    """
    parts = [str(part) for part in loc]
    key = ".".join([prefix, *parts] if prefix else parts)
    if kind == "extra_forbidden":
        msg = f"unknown key {parts[-1]!r}{did_you_mean(parts[-1], fields)}"
        if fields:
            msg += f"; valid keys: {', '.join(sorted(fields))}"
        return ConfigError(msg, key=key)
    if kind == "missing" and parts and parts[-1].isdigit():
        key = key.rsplit(".", 1)[0]
        return ConfigError(f"too few values, got {describe_value(value)}", key=key)
    msg = msg.replace("a valid tuple", "a list").replace("a valid dictionary", "a table")
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if kind not in ("value_error", "missing", "assertion_error"):
        msg = f"{msg[0].lower()}{msg[1:]}, got {describe_value(value)}"
    return ConfigError(msg, key=key)
