"""``robokit._dataclass.dataclass`` makes what ``dataclasses.dataclass`` makes, compiling each generated method on
first use: the same fields, parameters, signatures, ``repr``, ``==``, hashing, frozenness, ``replace``, ``asdict``,
pickling and subclassing; and robokit's own classes made with it match, method for method, twins made by the
standard decorator."""

from __future__ import annotations

import copy
import dataclasses
import inspect
import subprocess
import sys
import types
from dataclasses import FrozenInstanceError, InitVar, field
from typing import Any, ClassVar

import pytest

from robokit import _dataclass
from robokit._dataclass import dataclass as lazy_dataclass

GENERATED = ("__init__", "__repr__", "__eq__", "__hash__", "__setattr__", "__delattr__")
LAZY = _dataclass._LAZY


def _plain_function(obj: Any) -> Any:
    """The function behind a method (``__repr__``'s recursion guard wraps the generated one)."""
    return getattr(obj, "__wrapped__", obj)


def _code_of(fn: Any) -> tuple[Any, ...] | Any:
    """What a generated method is: its code, names, defaults and annotations (or the value itself if it is not a
    function, e.g. ``__hash__ = None`` or object's own slot)."""
    if not isinstance(fn, types.FunctionType):
        return fn
    inner = _plain_function(fn)
    code = inner.__code__
    return (fn.__name__, fn.__qualname__, code.co_code, code.co_names, code.co_varnames, code.co_consts,
            inner.__defaults__, inner.__kwdefaults__, inner.__annotations__)


def _assert_same_class(lazy: type, std: type) -> None:
    assert dataclasses.is_dataclass(lazy)
    assert [(f.name, f.type, f.default, f.default_factory, f.init, f.repr, f.hash, f.compare, f.kw_only,
             f._field_type) for f in dataclasses.fields(lazy)] == [  # type: ignore[attr-defined]
        (f.name, f.type, f.default, f.default_factory, f.init, f.repr, f.hash, f.compare, f.kw_only, f._field_type)
        for f in dataclasses.fields(std)]  # type: ignore[attr-defined]
    assert repr(lazy.__dataclass_params__) == repr(std.__dataclass_params__)  # type: ignore[attr-defined]
    assert getattr(lazy, "__match_args__", None) == getattr(std, "__match_args__", None)
    assert lazy.__doc__ == std.__doc__
    assert str(inspect.signature(lazy)) == str(inspect.signature(std))
    for name in GENERATED:
        assert _code_of(getattr(lazy, name)) == _code_of(getattr(std, name)), name


def _twin(cls: type, **options: Any) -> type:
    """``cls`` (a finished dataclass) made again from its own fields and methods by the standard decorator."""
    params = cls.__dataclass_params__  # type: ignore[attr-defined]
    options = {k: getattr(params, k) for k in ("init", "repr", "eq", "order", "unsafe_hash", "frozen")} | options
    namespace: dict[str, Any] = {}
    for name, value in cls.__dict__.items():
        if name in ("__dict__", "__weakref__", "__dataclass_fields__", "__dataclass_params__", "__match_args__"):
            continue
        inner = _plain_function(value)
        if name in GENERATED and (value is None or isinstance(value, _dataclass._Lazy)
                                  or getattr(getattr(inner, "__code__", None), "co_filename", "") == "<string>"):
            continue  # made by a decorator: the standard one makes its own
        namespace[name] = value
    for f in dataclasses.fields(cls):
        if f.name in cls.__dict__.get("__annotations__", {}):
            namespace[f.name] = field(default=f.default, default_factory=f.default_factory, init=f.init,
                                      repr=f.repr, hash=f.hash, compare=f.compare, metadata=f.metadata,
                                      kw_only=f.kw_only)  # type: ignore[call-overload]
    twin = type(cls.__name__, cls.__bases__, namespace)
    return dataclasses.dataclass(twin, **options)  # type: ignore[call-overload, no-any-return]


def _both(body: dict[str, Any], options: dict[str, Any] | None = None) -> tuple[type, type]:
    """The same class body decorated by robokit's decorator and by the standard one."""
    made = []
    for decorator in (lazy_dataclass, dataclasses.dataclass):
        namespace = {"__module__": __name__, "__qualname__": "Sample", **body}
        namespace = {k: (field(**v.kwargs) if isinstance(v, _F) else v) for k, v in namespace.items()}
        made.append(decorator(**(options or {}))(type("Sample", (), namespace)))  # type: ignore[call-overload]
    return made[0], made[1]


class _F:
    """A ``field(...)`` to make afresh for each decorated copy (a Field belongs to one class)."""

    def __init__(self, **kwargs: Any) -> None:
        self.kwargs = kwargs


def _post_init(self: Any, scale: float) -> None:
    object.__setattr__(self, "total", self.x * scale)


BODIES: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "plain": ({"__doc__": "Doc.", "__annotations__": {"x": "int", "y": "str"}, "y": "a"}, {}),
    "frozen": ({"__doc__": "Doc.", "__annotations__": {"x": "int", "y": "tuple"}, "y": ()}, {"frozen": True}),
    "frozen, not eq": ({"__doc__": "Doc.", "__annotations__": {"x": "int"}}, {"frozen": True, "eq": False}),
    "no repr, no init": ({"__doc__": "Doc.", "__annotations__": {"x": "int"}, "x": 3}, {"repr": False,
                                                                                      "init": False}),
    "fields": ({"__doc__": "Doc.", "__annotations__": {"x": "int", "items": "list", "hidden": "int",
                                                       "ignored": "int", "k": "int", "c": ClassVar[int]},
                "items": _F(default_factory=list), "hidden": _F(default=0, repr=False),
                "ignored": _F(default=5, compare=False, init=False), "k": _F(default=1, kw_only=True), "c": 7},
               {}),
    "post-init, InitVar": ({"__doc__": "Doc.", "__annotations__": {"x": float, "scale": InitVar[float],
                                                                   "total": float},
                            "total": _F(default=0.0, init=False), "__post_init__": _post_init}, {"frozen": True}),
    "own repr and eq": ({"__doc__": "Doc.", "__annotations__": {"x": "int"},
                         "__repr__": lambda self: "mine", "__eq__": lambda self, other: True}, {}),
    "explicit hash": ({"__doc__": "Doc.", "__annotations__": {"x": "int"}, "__hash__": lambda self: 42},
                      {"frozen": True}),
    "a field named self": ({"__doc__": "Doc.", "__annotations__": {"self": "int"}}, {}),
    "kw_only": ({"__doc__": "Doc.", "__annotations__": {"x": "int", "y": "int"}, "y": 2}, {"kw_only": True}),
    "no docstring": ({"__annotations__": {"x": "int"}}, {}),
}


@pytest.mark.parametrize("case", list(BODIES))
def test_same_class_as_the_standard_decorator(case: str) -> None:
    lazy, std = _both(*BODIES[case])
    _assert_same_class(lazy, std)


def test_nothing_is_compiled_before_first_use() -> None:
    lazy, std = _both(*BODIES["frozen"])
    if not LAZY:
        pytest.skip(f"Python {sys.version_info[:2]}: the standard decorator does the whole job")
    assert all(isinstance(lazy.__dict__[name], _dataclass._Lazy) for name in GENERATED)
    a = lazy(1)
    assert isinstance(lazy.__dict__["__init__"], types.FunctionType)
    assert isinstance(lazy.__dict__["__repr__"], _dataclass._Lazy)  # not used yet
    assert repr(a) == "Sample(x=1, y=())"
    assert isinstance(lazy.__dict__["__repr__"], types.FunctionType)


def test_instances_behave_the_same() -> None:
    lazy, std = _both(*BODIES["fields"])
    for cls in (lazy, std):
        a, b = cls(1, [2], 3, k=4), cls(1, [2], 3, k=4)
        assert repr(a) == "Sample(x=1, items=[2], ignored=5, k=4)"
        assert a == b and a is not b and not (a != b)
        assert a.ignored == 5 and cls.c == 7
        assert (a == 1) is False  # NotImplemented from both sides: falls back to identity
        assert dataclasses.asdict(a) == {"x": 1, "items": [2], "hidden": 3, "ignored": 5, "k": 4}
        assert dataclasses.replace(a, x=9) == cls(9, [2], 3, k=4)
        assert copy.deepcopy(a) == a and copy.copy(a) == a
        assert cls.__hash__ is None
        with pytest.raises(TypeError, match="unhashable"):
            hash(a)
        with pytest.raises(TypeError, match="missing 1 required positional argument: 'x'"):
            cls()
        match a:
            case cls(1, [2]):
                pass
            case _:
                pytest.fail("__match_args__ differs")


def test_frozen_instances_behave_the_same() -> None:
    lazy, std = _both(*BODIES["post-init, InitVar"])
    for cls in (lazy, std):
        a = cls(2.0, 3.0)
        assert a.total == 6.0 and repr(a) == "Sample(x=2.0, total=6.0)"
        assert hash(a) == hash(cls(2.0, 3.0)) == hash((2.0, 6.0))
        with pytest.raises(FrozenInstanceError, match="cannot assign to field 'x'"):
            a.x = 1.0
        with pytest.raises(FrozenInstanceError, match="cannot delete field 'x'"):
            del a.x
        assert dataclasses.replace(a, x=1.0, scale=1.0).total == 1.0


def test_recursive_repr_is_guarded() -> None:
    lazy, std = _both({"__doc__": "Doc.", "__annotations__": {"items": "list"}})
    for cls in (lazy, std):
        a = cls([])
        a.items.append(a)
        assert repr(a) == "Sample(items=[...])"


def test_subclasses_with_the_standard_decorator() -> None:
    lazy, std = _both(*BODIES["frozen"])
    for base in (lazy, std):
        sub = dataclasses.dataclass(frozen=True)(type("Sub", (base,), {"__annotations__": {"z": "int"}, "z": 0}))
        assert [f.name for f in dataclasses.fields(sub)] == ["x", "y", "z"]
        assert repr(sub(1, (2,), 3)) == "Sub(x=1, y=(2,), z=3)"
        with pytest.raises(TypeError, match="cannot inherit non-frozen dataclass from a frozen one"):
            dataclasses.dataclass(type("Bad", (base,), {}))
    # robokit's decorator on a subclass: made by the standard decorator, from the lazy base's fields
    sub_lazy = lazy_dataclass(frozen=True)(type("Sub", (lazy,), {"__doc__": "Doc.", "__annotations__": {"z": "int"},
                                                                 "z": 0}))
    assert sub_lazy(1, (), 2) == sub_lazy(1, (), 2) and hash(sub_lazy(1, (), 2)) == hash((1, (), 2))


def test_a_non_default_field_after_a_default_one_is_refused_at_once() -> None:
    for decorator in (lazy_dataclass, dataclasses.dataclass):
        cls = type("Bad", (), {"__doc__": "Doc.", "__annotations__": {"x": "int", "y": "int"}, "x": 1})
        with pytest.raises(TypeError, match="non-default argument 'y' follows default argument"):
            decorator(cls)


def _robokit_classes() -> list[type]:
    from robokit import components, compose, config, plugins, result, runner, scheduler, world
    from robokit.record import format as record_format

    return [plugins.PluginType, plugins.Plugins, config.ComponentSpec, config.Config,
            components.Outcome, components.GoalCheck, components.SetupContext, components.Delivery,
            result.RunResult, compose.Member, scheduler.Slot, scheduler.TickScheduler, world.JointInfo,
            runner.RunOutput, runner._UnbuiltReporter, record_format.Span, record_format.RunRecord,
            *_message_types()]


def _message_types() -> list[type]:
    """Every dataclass in :mod:`robokit.msgs` (the message types plugins exchange)."""
    from robokit import msgs

    return [v for v in vars(msgs).values() if isinstance(v, type) and dataclasses.is_dataclass(v)]


@pytest.mark.parametrize("cls", _robokit_classes(), ids=lambda c: f"{c.__module__}.{c.__qualname__}")
def test_robokit_classes_match_the_standard_decorator(cls: type) -> None:
    _assert_same_class(cls, _twin(cls))


def test_a_trivial_run_start_up_compiles_only_the_inits_it_calls() -> None:
    """In a fresh process, after importing what ``robokit run`` imports, no generated method is compiled yet."""
    if not LAZY:
        pytest.skip(f"Python {sys.version_info[:2]}: the standard decorator does the whole job")
    probe = """
import robokit.cli, robokit.config, robokit.runner
from robokit import _dataclass
import gc
classes = [c for c in gc.get_objects() if isinstance(c, type) and hasattr(c, "__dataclass_fields__")
           and c.__module__.startswith("robokit")]
lazy = [c.__qualname__ for c in classes if any(isinstance(v, _dataclass._Lazy) for v in vars(c).values())]
compiled = [f"{c.__qualname__}.{n}" for c in classes for n in ("__init__", "__repr__", "__eq__")
            if getattr(vars(c).get(n), "__code__", None) is not None and vars(c)[n].__code__.co_filename == "<string>"]
print(len(lazy), compiled)
"""
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.split()
    assert int(out[0]) >= 14  # Config, ComponentSpec, Plugins, RunResult, TickScheduler...
    assert out[1:] == ["[]"]
