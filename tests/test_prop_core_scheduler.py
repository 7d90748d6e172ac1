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
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.core.scheduler import Slot, TickScheduler, period_ticks
from robokit.errors import PluginError

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
