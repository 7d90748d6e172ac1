"""``dataclass``: :func:`dataclasses.dataclass` that compiles each generated method the first time it is used.

A dataclass compiles its ``__init__``, ``__repr__``, ``__eq__`` (and, when frozen, ``__hash__``, ``__setattr__``,
``__delattr__``) with one ``exec`` each when the class is created: about 3 M instructions a class, a tenth of a
trivial ``robokit run`` for robokit's 18 classes on that path, most of it for methods the run never calls. Here
the standard decorator does everything else (fields, checks, ``__dataclass_fields__``, ``__match_args__``, the
``__dataclass_params__`` asked for), and each of those methods is a placeholder in the class until it is first
looked up, by a call, an ``==``, a ``repr()``, ``inspect.signature`` or plain attribute access; the placeholder
then asks :mod:`dataclasses` for the very function it would have made and puts it in its place. From then on the
class is what ``dataclasses.dataclass`` would have made: ``fields``, ``replace``, ``asdict``, ``is_dataclass``,
subclassing with ``@dataclasses.dataclass``, pickling all behave the same.

Where the laziness cannot be exact, the standard decorator does the whole job: a Python other than 3.10-3.12 (whose
private helpers this uses; 3.13 compiles a class's methods in one go anyway), a class without a docstring (the
standard decorator derives one from ``__init__``'s signature), a dataclass base class, ``order``, ``unsafe_hash``,
``slots``, an abstract base, or a frozen class defining ``__setattr__``/``__delattr__`` itself.

Type checkers see :func:`dataclasses.dataclass` itself.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import TYPE_CHECKING, Any

__all__ = ["dataclass"]

_LAZY = (3, 10) <= sys.version_info[:2] <= (3, 12)


class _Lazy:
    """A generated method not compiled yet: the first lookup compiles it and puts it in the class in its place."""

    __slots__ = ("owner", "name", "build")

    def __init__(self, owner: type, name: str, build: Any) -> None:
        self.owner, self.name, self.build = owner, name, build

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        fn = self.build()
        fn.__qualname__ = f"{self.owner.__qualname__}.{fn.__name__}"
        setattr(self.owner, self.name, fn)
        return fn.__get__(obj, objtype)

    def __repr__(self) -> str:
        return f"<{self.owner.__qualname__}.{self.name}, compiled on first use>"


if TYPE_CHECKING:
    from dataclasses import dataclass as dataclass
else:

    def dataclass(cls=None, /, *, init=True, repr=True, eq=True, order=False, unsafe_hash=False, frozen=False,
                  match_args=True, kw_only=False, slots=False):
        """:func:`dataclasses.dataclass`, with the generated methods compiled on first use (see the module)."""
        options = dict(init=init, repr=repr, eq=eq, order=order, unsafe_hash=unsafe_hash, frozen=frozen,
                       match_args=match_args, kw_only=kw_only, slots=slots)

        def wrap(cls):
            if not _can_defer(cls, options):
                return dataclasses.dataclass(cls, **options)
            return _deferred(cls, options)

        return wrap if cls is None else wrap(cls)


def _can_defer(cls: type, options: dict[str, Any]) -> bool:
    """Whether :func:`_deferred` makes exactly what the standard decorator would (see the module docstring)."""
    if not _LAZY or options["order"] or options["unsafe_hash"] or options["slots"]:
        return False
    if not cls.__dict__.get("__doc__"):
        return False
    if any(hasattr(base, "__dataclass_fields__") or getattr(base, "__abstractmethods__", None)
           for base in cls.__mro__[1:]):
        return False
    return not (options["frozen"] and ("__setattr__" in cls.__dict__ or "__delattr__" in cls.__dict__))


def _deferred(cls: type, options: dict[str, Any]) -> type:
    dc: Any = dataclasses
    init, repr_, eq, frozen = options["init"], options["repr"], options["eq"], options["frozen"]
    class_hash = cls.__dict__.get("__hash__", dc.MISSING)
    explicit_hash = not (class_hash is dc.MISSING or (class_hash is None and "__eq__" in cls.__dict__))
    cls = dc.dataclass(cls, init=False, repr=False, eq=False, frozen=False, match_args=options["match_args"],
                       kw_only=options["kw_only"])
    params = cls.__dataclass_params__  # type: ignore[attr-defined]
    params.init, params.repr, params.eq, params.frozen = init, repr_, eq, frozen
    globals_ = sys.modules[cls.__module__].__dict__ if cls.__module__ in sys.modules else {}
    fields = cls.__dataclass_fields__  # type: ignore[attr-defined]
    field_list = [f for f in fields.values() if f._field_type is dc._FIELD]
    own = cls.__dict__

    def lazy(name: str, build: Any) -> None:
        setattr(cls, name, _Lazy(cls, name, build))

    if init and "__init__" not in own:
        every = [f for f in fields.values() if f._field_type in (dc._FIELD, dc._FIELD_INITVAR)]
        _check_default_order(every)  # the standard decorator refuses such a class at once, not at the first call
        has_post_init = hasattr(cls, "__post_init__")
        self_name = "__dataclass_self__" if "self" in fields else "self"
        lazy("__init__", lambda: dc._init_fn(every, *dc._fields_in_init_order(every), frozen, has_post_init,
                                             self_name, globals_, False))
    if repr_ and "__repr__" not in own:
        lazy("__repr__", lambda: dc._repr_fn([f for f in field_list if f.repr], globals_))
    if eq and "__eq__" not in own:
        lazy("__eq__", lambda: _eq_fn([f for f in field_list if f.compare], globals_))
    if frozen:  # one helper makes both; each is compiled on its own first use
        lazy("__setattr__", lambda: dc._frozen_get_del_attr(cls, field_list, globals_)[0])
        lazy("__delattr__", lambda: dc._frozen_get_del_attr(cls, field_list, globals_)[1])
    action = dc._hash_action[False, bool(eq), bool(frozen), explicit_hash]
    if action is dc._hash_set_none:
        cls.__hash__ = None  # type: ignore[assignment]
    elif action is not None:  # _hash_add
        lazy("__hash__", lambda: action(cls, field_list, globals_))
    return cls


def _eq_fn(compared: list[Any], globals_: dict[str, Any]) -> Any:
    dc: Any = dataclasses
    return dc._cmp_fn("__eq__", "==", dc._tuple_str("self", compared), dc._tuple_str("other", compared),
                      globals=globals_)


def _check_default_order(fields: list[Any]) -> None:
    """No field without a default after one with a default, among ``__init__``'s positional parameters."""
    seen_default = False
    for f in fields:
        if not f.init or f.kw_only:
            continue
        if not (f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING):
            seen_default = True
        elif seen_default:
            raise TypeError(f"non-default argument {f.name!r} follows default argument")
