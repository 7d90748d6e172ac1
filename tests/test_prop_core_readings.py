"""Two watchers of a run, as properties over generated readings and call trees.

* The reading check (:mod:`robokit.core.reading_check`, docs/cli.md's non-finite warning): the path it names is the
  first NaN (or infinity, unless the sensor allows them) in reading order, written ``ranges[3]``, ``pose.x``,
  ``[1, 2]`` for an array, ``(value)`` for a bare number; huge finite numbers whose sum overflows are not flagged;
  a value that cannot be serialised is refused with its path. A sensor's first reading is walked in full, then every
  ``1 + values // 32``-th, counting an array as 16 values: a NaN in a reading it checks is always found.
* Wall time per component (:mod:`robokit.core.walltime`): each component is charged its own time (what it called
  is charged to the callee), its calls counted, the slowest named with its seconds and calls, and the component that
  was running when an exception broke out named; ``restore`` puts the real components back.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections import namedtuple
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.core.reading_check import ReadingCheck, Unserialisable, nonfinite_path
from robokit.core.walltime import WallTiming

FAST = settings(max_examples=30, deadline=None, derandomize=True, database=None)
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning:robokit.core.reading_check")  # numpy sums inf - inf

Pose = namedtuple("Pose", "x y")


@dataclasses.dataclass
class Hit:
    distance: Any
    body: Any


class Colour(enum.Enum):
    RED = 1.5


class Opaque:
    """Something no trace can hold."""


def bad_float(x: float, allow_inf: bool) -> bool:
    return math.isnan(x) or (math.isinf(x) and not allow_inf)


def first_problem(value: Any, allow_inf: bool, path: str = "") -> str | None:
    """The oracle: walk in reading order; the first NaN / infinity gives its path, something else raises."""
    if isinstance(value, (float, np.floating)):
        return (path or "(value)") if bad_float(float(value), allow_inf) else None
    if value is None or isinstance(value, (bool, int, str, enum.Enum, np.integer, np.bool_)):
        return None
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            for index in np.ndindex(value.shape):
                if bad_float(float(value[index]), allow_inf):
                    return f"{path}[{', '.join(str(i) for i in index)}]"
        return None
    if isinstance(value, tuple) and hasattr(value, "_fields"):
        items: Any = [(f".{n}", v) for n, v in zip(value._fields, value, strict=True)]
    elif isinstance(value, (list, tuple)):
        items = [(f"[{i}]", v) for i, v in enumerate(value)]
    elif isinstance(value, dict):
        items = [(f".{k}", v) for k, v in value.items()]
    elif dataclasses.is_dataclass(value):
        items = [(f".{f.name}", getattr(value, f.name)) for f in dataclasses.fields(value)]
    else:
        raise TypeError(path)
    for segment, item in items:
        found = first_problem(item, allow_inf, path + segment)
        if found is not None:
            return found
    return None


def render(path: str) -> str:
    return path.lstrip(".") or "(value)"


floats = st.one_of(st.floats(-1e3, 1e3), st.sampled_from([math.nan, math.inf, -math.inf, 1e308, -1e308]))
float32s = st.one_of(st.floats(-1e3, 1e3, width=32).map(np.float32),
                    st.sampled_from([np.float32(math.nan), np.float32(math.inf)]))
leaves = st.one_of(floats, float32s, st.integers(-5, 5), st.booleans(), st.none(), st.text("ab", max_size=2),
                   st.just(Colour.RED), st.integers(0, 9).map(np.int64),
                   st.lists(floats, min_size=1, max_size=4).map(lambda xs: np.array(xs, dtype=float)),
                   st.lists(floats, min_size=4, max_size=4).map(lambda xs: np.array(xs).reshape(2, 2)),
                   st.lists(st.integers(0, 5), max_size=3).map(np.array))
readings = st.recursive(leaves, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.lists(inner, max_size=3).map(tuple),
    st.dictionaries(st.sampled_from(["ranges", "pose", "a"]), inner, max_size=3),
    st.builds(Pose, inner, inner), st.builds(Hit, inner, inner)), max_leaves=14)


@FAST
@given(value=readings, allow_inf=st.booleans())
@example(value=Pose(np.float32(0.0), [0.0, np.array([0.0])]), allow_inf=False)  # numpy adds the list as an array
@example(value=[10**400, 1.0, math.nan], allow_inf=False)  # a sum that cannot be a float
def test_the_path_named_is_the_first_non_finite_value_in_reading_order(value: Any, allow_inf: bool) -> None:
    want = first_problem(value, allow_inf)
    said = None if want is None else render(want)
    assert nonfinite_path(value, allow_inf) == said
    check = ReadingCheck(allow_inf)  # the first reading is walked in full, counting its values; then on schedule
    assert check(value) == said
    assert [check(value) for _ in range(check.every)] == [None] * (check.every - 1) + [said]


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(value=readings, where=st.integers(0, 50))
def test_something_that_cannot_be_serialised_is_refused_with_its_path(value: Any, where: int) -> None:
    opaque = Opaque()
    box = {"data": [value, opaque]} if where % 2 else {"data": Pose(opaque, value)}
    want = first_problem(value, False, ".data" + ("[0]" if where % 2 else ".y"))
    if where % 2 and want is not None:  # a NaN before it is reported first
        assert nonfinite_path(box) == render(want)
        return
    with pytest.raises(Unserialisable) as info:
        nonfinite_path(box)
    path = "data[1]" if where % 2 else "data.x"
    assert info.value.path == path and info.value.value_type == "Opaque" and info.value.value is opaque
    assert str(info.value) == f"{path} is a Opaque"  # what the run's one line says
    with pytest.raises(Unserialisable) as bare:
        ReadingCheck()(opaque)
    assert bare.value.path == "" and bare.value.value is opaque and str(bare.value) == "the reading is a Opaque"


def count(value: Any) -> int:
    """Values a reading counts for: one per number, bool, string, None; 16 per numpy array."""
    if isinstance(value, np.ndarray):
        return 16
    if isinstance(value, dict):
        return sum(count(v) for v in value.values())
    if dataclasses.is_dataclass(value):
        return sum(count(getattr(value, f.name)) for f in dataclasses.fields(value))
    if isinstance(value, (list, tuple)):
        return sum(count(v) for v in value)
    return 1


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(size=st.integers(1, 200), arrays=st.integers(0, 3), n=st.integers(1, 60), nan_at=st.sets(st.integers(0, 59)),
       spot=st.integers(0, 10**6))
def test_readings_are_checked_on_a_schedule_set_by_the_first_readings_size(size: int, arrays: int, n: int,
                                                                          nan_at: set[int], spot: int) -> None:
    def reading(i: int) -> dict[str, Any]:
        values = [0.5] * size
        if i in nan_at:
            values[spot % size] = math.nan
        return {"values": values, "extra": [np.zeros(2) for _ in range(arrays)]}

    every = 1 + count(reading(-1)) // 32
    check = ReadingCheck()
    for i in range(n):
        found = check(reading(i))
        checked = i % every == 0
        assert found == (f"values[{spot % size}]" if checked and i in nan_at else None), (i, every)
    assert check.checked == len(range(0, n, every)) and check.every == every


class Part:
    """A component whose calls take the time the test says, on the test's clock, and call others."""

    def __init__(self, kind: str, clock: list[float]) -> None:
        self.kind = kind
        self.clock = clock
        self.marker = object()

    def read(self, plan: Any, parts: dict[str, Any]) -> None:
        own, calls, fail = plan
        self.clock[0] += own
        for name, inner in calls:
            parts[name].read(inner, parts)
        if fail:
            raise KeyError("stop")

    step = update = command = read


NAMES = ["a", "b", "c"]
plans = st.recursive(st.tuples(st.floats(0, 5), st.just(()), st.just(False)),
                     lambda inner: st.tuples(st.floats(0, 5), st.lists(st.tuples(st.sampled_from(NAMES + ["beh"]),
                                                                                  inner), max_size=3).map(tuple),
                                             st.just(False)), max_leaves=8)


def charge(plan: Any, name: str, spent: dict[str, float], calls: dict[str, int]) -> None:
    own, inner, _ = plan
    spent[name] = spent.get(name, 0.0) + own
    calls[name] = calls.get(name, 0) + 1
    for callee, p in inner:
        charge(p, callee, spent, calls)


def innermost(plan: Any, name: str) -> Any:
    """Mark the deepest last call of a plan to fail; returns the plan and who fails."""
    own, inner, _ = plan
    if not inner:
        return (own, inner, True), name
    *before, (callee, last) = inner
    changed, who = innermost(last, callee)
    return (own, (*before, (callee, changed)), False), who


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(top=st.lists(st.tuples(st.sampled_from(NAMES + ["beh"]), plans), min_size=1, max_size=4), fail=st.booleans(),
       method=st.sampled_from(["read", "update", "command", "step"]))
def test_each_component_is_charged_its_own_time_and_the_slowest_is_named(top: list[Any], fail: bool,
                                                                       method: str) -> None:
    clock = [0.0]
    parts = {n: Part("sensor", clock) for n in NAMES}
    behaviour = Part("behaviour", clock)
    scheduler = SimpleNamespace(slots={n: SimpleNamespace(component=parts[n], name=n, origin=f"type {n!r}")
                                       for n in NAMES}, behaviour=behaviour, behaviour_origin="type 'beh'")
    timing = WallTiming(scheduler, lambda: clock[0])
    label = {n: f"sensor {n!r} (type {n!r})" for n in NAMES} | {"beh": "behaviour (type 'beh')"}
    wrapped = {n: scheduler.slots[n].component for n in NAMES} | {"beh": scheduler.behaviour}
    assert all(wrapped[n].marker is parts[n].marker for n in NAMES)  # everything else is forwarded
    spent: dict[str, float] = {}
    calls: dict[str, int] = {}
    who = None
    if fail:  # the last call's innermost component raises
        plan, who = innermost(top[-1][1], top[-1][0])
        top[-1] = (top[-1][0], plan)
    for name, plan in top:
        charge(plan, name, spent, calls)
        try:
            getattr(wrapped[name], method)(plan, wrapped)
        except KeyError:
            assert fail
    for name in spent:
        assert timing.spent[label[name]] == pytest.approx(spent[name], abs=1e-9)
        assert timing.calls[label[name]] == calls[name]
    assert set(timing.spent) == {label[n] for n in spent} and timing.stack == []
    slowest = max(spent.values())
    text = timing.slowest()
    named = text.split(" ", 2)[0] + " " + text.split(" ", 2)[1]
    name = next(n for n in spent if label[n].startswith(named))
    assert spent[name] == pytest.approx(slowest, abs=1e-9)
    head = f"{label[name]} {timing.spent[label[name]]:.2f} s in {calls[name]} call(s)"
    if who is None:
        assert text == head and timing.stopped_in is None
    else:
        assert timing.stopped_in == label[who]
        assert text == head + (" (stopped inside it)" if who == name else f" (stopped inside {label[who]})")
    timing.restore()
    assert all(scheduler.slots[n].component is parts[n] for n in NAMES) and scheduler.behaviour is behaviour
