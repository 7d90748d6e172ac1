"""The one loop's order and rates over generated components, judged by the order written in its docs.

``robokit.core.scheduler``'s docstring fixes what happens in tick ``k``: monitors due sample, sensors due are marked
stale (lazy) or read now, the behaviour steps if due and its commands go to the actuators at once, actuators due
update, the tick's events are applied, physics steps. A stale sensor is computed the first time something reads it.
Here the components are stand-ins that note every call, with generated periods, laziness, which sensors the
behaviour reads, which actuators it commands, when it ends and when events come; the expected log of calls is
worked out tick by tick below from those rules alone, and compared call for call.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.core.scheduler import Readings, Slot, TickScheduler, period_ticks
from robokit.errors import Interrupted, PluginError

DT = 1.0 / 240.0
TICKS = 13
PROPS = settings(max_examples=60, deadline=None, derandomize=True)


class World:
    def __init__(self, log: list[tuple[Any, ...]]) -> None:
        self.tick, self.time_step, self.log = 0, DT, log

    @property
    def time(self) -> float:
        return self.tick * self.time_step

    def step(self) -> None:
        self.log.append((self.tick, "physics"))
        self.tick += 1


class Sensor:
    kind = "sensor"

    def __init__(self, name: str, world: World) -> None:
        self.name, self.world = name, world

    def read(self) -> tuple[str, int]:
        self.world.log.append((self.world.tick, "read", self.name))
        return (self.name, self.world.tick)


class Actuator:
    kind = "actuator"

    def __init__(self, name: str, world: World) -> None:
        self.name, self.world = name, world

    def command(self, cmd: Any) -> None:
        self.world.log.append((self.world.tick, "command", self.name, cmd))

    def update(self) -> None:
        self.world.log.append((self.world.tick, "update", self.name))

    def read(self) -> str:
        return self.name


class Monitor:
    def __init__(self, name: str, period: int, world: World) -> None:
        self.name, self.period, self.world = name, period, world

    def sample(self, tick: int) -> None:
        self.world.log.append((self.world.tick, "sample", self.name, tick))


class Behaviour:
    def __init__(self, reads: list[str], commands: list[str], ends_at: int | None, world: World) -> None:
        self.reads, self.commands, self.ends_at, self.world = reads, commands, ends_at, world
        self.outcome: Any = None
        self.seen: list[tuple[int, dict[str, Any], dict[str, int]]] = []

    def step(self, readings: Mapping[str, Any], t: float) -> dict[str, Any]:
        k = self.world.tick
        self.world.log.append((k, "step", round(t / DT)))
        got = {name: readings[name] for name in self.reads}
        self.seen.append((k, got, {name: readings.stamp(name) for name in self.reads}))  # type: ignore[attr-defined]
        if self.ends_at is not None and k >= self.ends_at:
            self.outcome = "done"
        return {name: k for name in self.commands}


component = st.tuples(st.integers(1, 4), st.booleans())  # period, lazy


@PROPS
@given(st.lists(component, min_size=0, max_size=3), st.lists(st.integers(1, 3), max_size=2),
       st.lists(st.integers(1, 3), max_size=2), st.integers(1, 4), st.data())
def test_every_tick_runs_its_components_in_the_documented_order(sensors: list, actuators: list, monitors: list,
                                                                 behaviour_period: int, data: Any) -> None:
    log: list[tuple[Any, ...]] = []
    world = World(log)
    s_names = [f"s{i}" for i in range(len(sensors))]
    a_names = [f"a{i}" for i in range(len(actuators))]
    reads = data.draw(st.lists(st.sampled_from(s_names), unique=True) if s_names else st.just([]))
    commands = data.draw(st.lists(st.sampled_from(a_names), unique=True) if a_names else st.just([]))
    ends_at = data.draw(st.one_of(st.none(), st.integers(0, TICKS)))
    events = data.draw(st.dictionaries(st.integers(0, TICKS + 2), st.integers(1, 2), max_size=4))
    sensor_slots = {n: Slot(n, Sensor(n, world), p, "test", lambda: world.tick, lazy=lazy)
                    for n, (p, lazy) in zip(s_names, sensors, strict=True)}
    actuator_slots = {n: Slot(n, Actuator(n, world), p, "test", lambda: world.tick)
                      for n, p in zip(a_names, actuators, strict=True)}
    mons = [Monitor(f"m{i}", p, world) for i, p in enumerate(monitors)]
    behaviour = Behaviour(reads, commands, ends_at, world)
    actions = {k: [lambda k=k, j=j: log.append((world.tick, "event", k, j)) for j in range(n)]
               for k, n in events.items()}
    scheduler = TickScheduler(world, sensor_slots, actuator_slots, behaviour, behaviour_period, "test",
                              events=actions, monitors=mons)
    for _ in range(TICKS):
        scheduler.tick()

    # the oracle: the docstring's order, tick by tick, with staleness kept as a plain set
    want: list[tuple[Any, ...]] = []
    stale, computed_at = set(s_names), dict.fromkeys(s_names, -1)
    ended, seen = False, []
    for k in range(TICKS):
        want += [(k, "sample", f"m{i}", k) for i, p in enumerate(monitors) if k % p == 0]
        for name, (p, lazy) in zip(s_names, sensors, strict=True):
            if k % p == 0:
                stale.add(name)
                if not lazy:
                    want.append((k, "read", name))
                    stale.discard(name)
                    computed_at[name] = k
        if k % behaviour_period == 0 and not ended:
            want.append((k, "step", k))
            for name in reads:
                if name in stale:
                    want.append((k, "read", name))
                    stale.discard(name)
                    computed_at[name] = k
            seen.append((k, {n: (n, computed_at[n]) for n in reads}, {n: computed_at[n] for n in reads}))
            ended = ends_at is not None and k >= ends_at
            want += [(k, "command", name, k) for name in commands]
        want += [(k, "update", name) for name, p in zip(a_names, actuators, strict=True) if k % p == 0]
        want += [(k, "event", k, j) for j in range(events.get(k, 0))]
        want.append((k, "physics"))
    assert log == want
    assert behaviour.seen == seen  # each reading as of the tick it was computed, stamped with that tick
    for name in s_names:  # how often each was computed: the reads in the log
        assert scheduler.readings.computed(name) == sum(1 for x in log if x[1:] == ("read", name))
    assert all(k > TICKS - 1 for k in scheduler.events)  # events of ticks run are applied once, and gone


@given(st.floats(1.0, 2000.0), st.one_of(st.none(), st.floats(0.01, 5000.0)))
@settings(max_examples=100, deadline=None, derandomize=True)
def test_a_rate_is_the_nearest_whole_number_of_ticks_and_at_least_one(physics_hz: float, rate: float | None) -> None:
    got = period_ticks(rate, physics_hz)
    if rate is None:
        assert got == 1
        return
    assert got >= 1
    if physics_hz / rate >= 1:  # the nearest whole number of ticks to the asked period
        assert abs(got - physics_hz / rate) <= 0.5 + 1e-9
    else:  # faster than physics: every tick
        assert got == 1


def test_a_command_to_an_unknown_actuator_names_it_and_the_actuators_there_are() -> None:
    log: list[tuple[Any, ...]] = []
    world = World(log)
    slots = {n: Slot(n, Actuator(n, world), 1, "test", lambda: world.tick) for n in ("arm", "base")}
    scheduler = TickScheduler(world, {}, slots, Behaviour([], ["gripper"], None, world), 1, "type 'b' from tests")
    with pytest.raises(PluginError) as err:
        scheduler.tick()
    assert str(err.value) == ("behaviour (type 'b' from tests) sent a command to unknown actuator 'gripper'; "
                              "actuators: arm, base")
    assert err.value.type_name == "type 'b' from tests"


# ------------------------------------------------------------------------------------------ faults
def boom(exc: BaseException) -> None:
    raise exc


BOOM_AT = f"{boom.__code__.co_filename}:{boom.__code__.co_firstlineno + 1}"


def where(path_line: str) -> str:
    """``file:line`` as an error shows it: relative to the working directory when under it."""
    path, line = path_line.rsplit(":", 1)
    try:
        return f"{Path(path).resolve().relative_to(Path.cwd())}:{line}"
    except ValueError:
        return path_line


class Faulty:
    """A sensor, actuator or behaviour whose ``read``/``update``/``command``/``step`` raises at a given tick."""

    def __init__(self, kind: str, world: World, method: str, at: int, exc: BaseException) -> None:
        self.kind, self.world, self.method, self.at, self.exc = kind, world, method, at, exc
        self.outcome: Any = None
        self.commands: dict[str, Any] = {}

    def _maybe(self, method: str) -> None:
        if method == self.method and self.world.tick == self.at:
            boom(self.exc)

    def read(self) -> int:
        self._maybe("read")
        return self.world.tick

    def update(self) -> None:
        self._maybe("update")

    def command(self, cmd: Any) -> None:
        self._maybe("command")

    def step(self, readings: Mapping[str, Any], t: float) -> dict[str, Any]:
        self._maybe("step")
        for name in readings:
            readings[name]
        return self.commands


faults = st.sampled_from([ValueError("bad value"), KeyError("gone"), ZeroDivisionError("division by zero"),
                          SystemExit(3), KeyboardInterrupt(), RuntimeError("")])


@PROPS
@given(st.sampled_from(["read", "update", "command", "step"]), st.integers(0, 5), faults,
       st.sampled_from(["cam", "arm_1"]), st.sampled_from(["type 'x' from pkg 1.0", "lidar (robokit)"]))
def test_a_component_that_raises_is_named_with_its_origin_and_where_it_raised(method: str, at: int,
                                                                            exc: BaseException, name: str,
                                                                            origin: str) -> None:
    """The loop turns anything a plugin raises (SystemExit and KeyboardInterrupt too) into a PluginError naming the
    component, its origin, the call, the exception and the file and line that raised, at the tick it raised."""
    log: list[tuple[Any, ...]] = []
    world = World(log)
    sensors: dict[str, Slot] = {}
    actuators: dict[str, Slot] = {}
    behaviour: Any = Behaviour([], [], None, world)
    if method == "read":
        sensors[name] = Slot(name, Faulty("sensor", world, "read", at, exc), 1, origin, lambda: world.tick)
        behaviour = Behaviour([name], [], None, world)
    elif method in ("update", "command"):
        actuators[name] = Slot(name, Faulty("actuator", world, method, at, exc), 1, origin, lambda: world.tick)
        behaviour = Behaviour([], [name], None, world)
    else:
        behaviour = Faulty("behaviour", world, "step", at, exc)
    scheduler = TickScheduler(world, sensors, actuators, behaviour, 1, origin)
    with pytest.raises(PluginError) as err:
        for _ in range(8):
            scheduler.tick()
    assert world.tick == at  # raised in that tick, before its physics step
    text = str(exc)
    fault = f"{type(exc).__name__}: {text}" if text and not isinstance(exc, KeyError) else (
        f"{type(exc).__name__}: {exc.args[0]!r}" if isinstance(exc, KeyError) else type(exc).__name__)
    fault += f" (at {where(BOOM_AT)})"
    if method == "step":
        assert str(err.value) == f"behaviour ({origin}) raised during step: {fault}"
    else:
        kind = "sensor" if method == "read" else "actuator"
        assert str(err.value) == f"{kind} {name!r} ({origin}) raised during {method}: {fault}"
    assert err.value.type_name == origin
    assert err.value.__cause__ is exc


@PROPS
@given(st.sampled_from(["read", "update", "command", "step"]),
       st.sampled_from([PluginError("already said", type_name="inner"), Interrupted("stop")]))
def test_plugin_errors_and_interrupts_pass_through_as_they_are(method: str, exc: BaseException) -> None:
    log: list[tuple[Any, ...]] = []
    world = World(log)
    comp = Faulty("sensor" if method == "read" else "actuator", world, method, 0, exc)
    slots = {"c": Slot("c", comp, 1, "o", lambda: world.tick)}
    if method == "step":
        scheduler = TickScheduler(world, {}, {}, Faulty("behaviour", world, "step", 0, exc), 1, "o")
    elif method == "read":
        scheduler = TickScheduler(world, slots, {}, Behaviour(["c"], [], None, world), 1, "o")
    else:
        scheduler = TickScheduler(world, {}, slots, Behaviour([], ["c"], None, world), 1, "o")
    with pytest.raises(type(exc)) as err:
        scheduler.tick()
    assert err.value is exc


def test_a_command_with_no_actuators_at_all_says_none() -> None:
    world = World([])
    scheduler = TickScheduler(world, {}, {}, Behaviour([], ["x"], None, world), 1, "b")
    with pytest.raises(PluginError, match=r"unknown actuator 'x'; actuators: \(none\)$"):
        scheduler.tick()


# ------------------------------------------------------------------------------------------ a slot alone
@PROPS
@given(st.integers(0, 6), st.integers(1, 4))
def test_a_new_slot_is_lazy_stale_never_stamped_and_checked_after_each_reading(start: int, reads: int) -> None:
    """Before anything reads it a slot has no stamp (-1) and nothing computed; the first read computes it (at the
    clock's tick) and calls ``check`` with the slot; further reads in the same tick compute nothing. A slot built
    without ``lazy`` is lazy: the loop computes it only when read."""
    log: list[tuple[Any, ...]] = []
    world = World(log)
    world.tick = start
    checked: list[tuple[str, Any, int]] = []
    slot = Slot("s", Sensor("s", world), 1, "o", lambda: world.tick,
                check=lambda s: checked.append((s.name, s.value, s.stamp)))
    assert (slot.stamp, slot.computed, slot.lazy) == (-1, 0, True)
    assert Readings({"s": slot}).stamp("s") == -1
    for _ in range(reads):
        assert slot.get() == ("s", start)
    assert (slot.stamp, slot.computed) == (start, 1)
    assert checked == [("s", ("s", start), start)]
    scheduler = TickScheduler(world, {"s": slot}, {}, None, 1, "o")
    scheduler.tick()
    scheduler.tick()
    assert slot.computed == 1  # marked stale twice, never read: nothing computed
    assert slot.get() == ("s", start + 2) and checked[-1] == ("s", ("s", start + 2), start + 2)


# ------------------------------------------------------------------------------------------ GUI pacing
STEP = 1.0 / 256.0  # a physics step and wall-clock times in powers of two: every sum here is exact


@PROPS
@given(st.integers(0, 50), st.lists(st.sampled_from([0.0, STEP / 2, STEP, 2 * STEP, 16 * STEP]), min_size=1,
                                    max_size=12))
def test_pacing_sleeps_exactly_as_far_as_sim_time_is_ahead_of_the_wall_clock(start_tick: int,
                                                                            wall_steps: list[float]) -> None:
    """``pace`` takes the wall-clock time matching the sim time at its first call, then sleeps by how far sim time
    has run ahead of the wall clock since, and not at all when it is not ahead."""
    world = World([])
    world.tick, world.time_step = start_tick, STEP
    wall = [64.0]
    sleeps: list[float] = []
    scheduler = TickScheduler(world, {}, {}, None, 1, "o", wall_clock=lambda: wall[0], sleep=sleeps.append)
    scheduler.pace()  # the first call starts pacing and never sleeps
    assert sleeps == []
    want = []
    for step in wall_steps:
        world.step()
        wall[0] += step
        scheduler.pace()
        ahead = (world.tick - start_tick) * STEP - (wall[0] - 64.0)
        if ahead > 0:
            want.append(ahead)
    assert sleeps == want
