"""The one loop. Fixed physics step; each component runs at its own rate in Hz of *sim* time.

Order inside a tick (tick ``k``, sim time ``t = k * dt``), fixed:

0. **monitors** whose period divides ``k`` sample the scene as it is at ``t`` (the recorder's pose log);
1. **sensors** whose period divides ``k`` are marked stale (lazy ones) or read now (``lazy = False``);
2. **behaviour**, if due, steps with the readings and ``t``; its commands go to the actuators at once;
3. **actuators** whose period divides ``k`` run ``update()``;
4. **events** scheduled for tick ``k`` (forces, teleports, removals) are applied;
5. **physics**: one ``stepSimulation``; the clock becomes ``k + 1``.

A stale sensor is computed the first time something reads it; a camera nobody looks at costs nothing. There is no
wall clock in any of this: real-time pacing exists only for the GUI (:meth:`TickScheduler.pace`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from typing import Any

from robokit.errors import Interrupted, PluginError, plugin_fault


def period_ticks(rate_hz: float | None, physics_hz: float) -> int:
    """Ticks between runs of a component with ``rate_hz`` (None = every tick)."""
    if rate_hz is None:
        return 1
    return max(1, round(physics_hz / rate_hz))


class Slot:
    """One sensor or actuator in the loop: its period, staleness and latest reading.

    ``origin`` names the type and distribution for error messages; ``check`` is called after each computed reading
    (sensors: flags non-finite values, refuses non-serialisable ones). A slot is a piece of the loop's state,
    compared by identity: a plain class (a dataclass would compile an ``__init__`` and a ``__repr__`` at every
    start-up for nothing).
    """

    def __init__(self, name: str, component: Any, period: int, origin: str, clock: Callable[[], int],
                 lazy: bool = True, check: Callable[[Slot], None] | None = None) -> None:
        self.name = name
        self.component = component
        self.period = period
        self.origin = origin
        self.clock = clock
        self.lazy = lazy
        self.check = check
        self.stale = True
        self.value: Any = None
        self.stamp = -1
        self.computed = 0

    def get(self) -> Any:
        """The latest reading, computing it first if the slot is stale."""
        if self.stale:
            try:
                self.value = self.component.read()
            except BaseException:  # noqa: BLE001 - re-raised by guarded() with the component named
                guarded(self, "read", _reraise)
            self.stamp = self.clock()
            self.stale = False
            self.computed += 1
            if self.check is not None:
                self.check(self)
        return self.value


def guarded(slot: Slot, what: str, fn: Callable[..., Any], *args: Any) -> Any:
    """Call a plugin method; turn anything it raises (``SystemExit`` and ``KeyboardInterrupt`` included) into a
    :class:`PluginError` naming the component, its origin, and the file and line that raised. robokit's own
    :class:`~robokit.errors.Interrupted` (Ctrl-C, the wall-clock watchdog) passes through."""
    try:
        return fn(*args)
    except (PluginError, Interrupted):
        raise
    except BaseException as exc:
        raise PluginError(
            f"{slot.component.kind} {slot.name!r} ({slot.origin}) raised during {what}: {plugin_fault(exc)}",
            type_name=slot.origin,
        ) from exc


class Readings(Mapping[str, Any]):
    """Read-only view of every sensor's and actuator's latest reading, by component name.

    Indexing computes a stale reading on demand. :meth:`stamp` gives the tick a reading was computed at.
    """

    def __init__(self, slots: Mapping[str, Slot]) -> None:
        self._slots = slots

    def __getitem__(self, name: str) -> Any:
        return self._slots[name].get()

    def __iter__(self) -> Iterator[str]:
        return iter(self._slots)

    def __len__(self) -> int:
        return len(self._slots)

    def stamp(self, name: str) -> int:
        """Tick at which the current reading of ``name`` was computed (-1 if never)."""
        return self._slots[name].stamp

    def computed(self, name: str) -> int:
        """How many times ``name``'s reading has been computed so far (e.g. camera frames rendered)."""
        return self._slots[name].computed


class TickScheduler:
    """Runs sensors, the behaviour, actuators, events and physics in the documented order, one tick at a time.

    ``events`` are actions by tick; ``monitors`` are observers with ``period`` (ticks) and ``sample(tick)``, which
    read the world and never change it. ``wall_clock`` (seconds) and ``sleep`` are GUI pacing's, replaceable so
    pacing can be tested without waiting.
    """

    def __init__(self, world: Any, sensors: dict[str, Slot], actuators: dict[str, Slot], behaviour: Any | None,
                 behaviour_period: int, behaviour_origin: str,
                 events: dict[int, list[Callable[[], None]]] | None = None, monitors: list[Any] | None = None,
                 wall_clock: Callable[[], float] = time.perf_counter,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.world = world
        self.sensors = sensors
        self.actuators = actuators
        self.behaviour = behaviour
        self.behaviour_period = behaviour_period
        self.behaviour_origin = behaviour_origin
        self.events: dict[int, list[Callable[[], None]]] = {} if events is None else events
        self.monitors: list[Any] = [] if monitors is None else monitors
        self.wall_clock = wall_clock
        self.sleep = sleep
        self._wall_start: float | None = None
        self.slots: dict[str, Slot] = {**self.sensors, **self.actuators}
        self.readings = Readings(self.slots)
        self._sensor_list = list(self.sensors.values())
        self._actuator_list = list(self.actuators.values())

    def tick(self) -> None:
        """Run one tick (see the module docstring for the order). This is the hot loop: kept lean on purpose."""
        k = self.world.tick
        for monitor in self.monitors:
            if k % monitor.period == 0:
                monitor.sample(k)
        for slot in self._sensor_list:
            if k % slot.period == 0:
                slot.stale = True
                if not slot.lazy:
                    slot.get()
        for slot in self._actuator_list:
            slot.stale = True  # actuator state is cheap; recomputed on read each tick
        behaviour = self.behaviour
        if behaviour is not None and k % self.behaviour_period == 0 and behaviour.outcome is None:
            self._step_behaviour(behaviour, self.world.time)
        for slot in self._actuator_list:
            if k % slot.period == 0:
                try:
                    slot.component.update()
                except BaseException:  # noqa: BLE001 - re-raised by guarded() with the component named
                    guarded(slot, "update", _reraise)
        if self.events:
            for action in self.events.pop(k, ()):
                action()
        self.world.step()

    def _step_behaviour(self, behaviour: Any, t: float) -> None:
        """Step the behaviour at sim time ``t`` (the world's clock) and hand its commands to the actuators."""
        try:
            commands = behaviour.step(self.readings, t)
        except (PluginError, Interrupted):
            raise
        except BaseException as exc:
            raise PluginError(
                f"behaviour ({self.behaviour_origin}) raised during step: {plugin_fault(exc)}",
                type_name=self.behaviour_origin,
            ) from exc
        if not commands:
            return
        for name, cmd in commands.items():
            slot = self.actuators.get(name)
            if slot is None:
                raise PluginError(
                    f"behaviour ({self.behaviour_origin}) sent a command to unknown actuator {name!r}; "
                    f"actuators: {', '.join(self.actuators) or '(none)'}",
                    type_name=self.behaviour_origin,
                )
            guarded(slot, "command", slot.component.command, cmd)

    def start_pacing(self) -> None:
        """GUI only: take the wall-clock time that corresponds to the current sim time (call before the loop)."""
        self._wall_start = self.wall_clock() - self.world.time

    def pace(self) -> None:
        """GUI only: sleep so that sim time does not run ahead of wall-clock time."""
        now = self.wall_clock()
        if self._wall_start is None:
            self.start_pacing()
            return
        ahead = self.world.time - (now - self._wall_start)
        if ahead > 0:
            self.sleep(ahead)


def _reraise() -> None:
    """Re-raise the exception being handled (lets :func:`guarded` wrap an error caught in the hot loop)."""
    raise  # noqa: PLE0704
