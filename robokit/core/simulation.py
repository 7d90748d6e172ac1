"""Simulation: wires a validated Config, the plugin types and one World together, and runs the loop."""

from __future__ import annotations

import copy
import datetime as dt
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit import __version__
from robokit.components import SetupContext
from robokit.config import BodyConfig, ComponentSpec, Config
from robokit.core.result import RunResult
from robokit.core.scheduler import Slot, TickScheduler, period_ticks
from robokit.core.world import World, to_quaternion
from robokit.errors import ConfigError, Interrupted, PluginError, UserError, plugin_fault
from robokit.plugin_api.plugins import Plugins
from robokit.process.interrupts import StopGuard

if TYPE_CHECKING:  # imported where used: a run without monitors, sensors or a wall-clock budget needs none of them
    from robokit.core.composites import Member
    from robokit.core.randomize import Randomizer
    from robokit.core.reading_check import ReadingCheck
    from robokit.core.walltime import WallTiming


class Simulation:
    """One run: a World built from a Config, its components set up, and the tick scheduler.

    Args:
        config: A validated config.
        plugins: The plugin types the config was validated against.
        gui: Override ``world.gui``.
        seed: Override ``world.seed``.
        randomize_rng: Draw ``[randomize]`` from this generator instead of the run's own randomisation stream
            (robokit.gym's episodes).
    """

    def __init__(self, config: Config, plugins: Plugins, *, gui: bool | None = None, seed: int | None = None,
                 run_id: str | None = None, run_dir: Path | None = None, save_frames: bool = False,
                 randomize_rng: np.random.Generator | None = None) -> None:
        self.config = config
        self.run_id = run_id or str(uuid.uuid4())
        self.run_dir = run_dir
        """The run's record folder, if it keeps one (cameras with ``save = true`` write their frames there)."""
        self.save_frames = save_frames or config.record.save_frames
        self.plugins = plugins
        wc = config.world
        self.seed = wc.seed if seed is None else int(seed)
        engine = World.engine_class(wc.engine)  # first: a missing engine is one line naming its extra
        engine.check_config(config, gui=gui)  # what the engine cannot honour is refused before the run
        self.world: World = engine(
            gui=wc.gui if gui is None else gui,
            time_step=wc.time_step,
            gravity=wc.gravity,
            solver_iterations=wc.solver_iterations,
            seed=self.seed,
            base_dir=config.base_dir,
        )
        self.trace: list[dict[str, Any]] = []
        self.trace_listeners: list[Callable[[dict[str, Any]], None]] = []
        self.components: dict[str, Any] = {}
        self.behaviour: Any = None
        self._origins: dict[str, str] = {}
        self.body_keys: dict[str, str] = {}
        self._contexts: dict[str, SetupContext] = {}
        self._instances: dict[str, Any] = {}
        self.monitors: list[Member] = []
        self._stop_reason: str | None = None
        self.interrupted = False
        self._halt = False  # set by interrupt() and the wall-clock watchdog; the loop checks it every tick
        self._wall_expired = False
        self.flags: dict[str, dict[str, Any]] = {}
        self._checks: dict[str, ReadingCheck] = {}
        """Non-finite readings seen, by sensor name: ``count``, ``first_tick``, ``field`` (see :meth:`run`)."""
        self.error: BaseException | None = None
        """What ended the run with outcome ``error`` (its ``__cause__`` is the plugin's own exception)."""
        self._randomize_rng = randomize_rng
        self.randomizer: Randomizer | None = None
        """The ``[randomize]`` draws of this run (None without the section), see :mod:`robokit.core.randomize`."""
        try:
            self._build()
        except BaseException:
            self.close()
            raise

    # ----------------------------------------------------------------- building
    def _build(self) -> None:
        cfg = self.config
        try:
            spawn_bodies(self.world, cfg, self.body_keys)
        except UserError as exc:
            raise _as_config_error(exc, "bodies", cfg.source) from None
        if cfg.randomize is not None:
            self._randomize(cfg.randomize, self._randomize_rng)
        if self.world.gui:
            from robokit.core.gui import apply_view

            apply_view(self.world, cfg.gui)
        hz = self.world.physics_hz
        slots: dict[str, Slot] = {}
        for spec in cfg.sensors + cfg.actuators:
            comp = self._instantiate(spec)
            lazy = getattr(comp, "lazy", True) if spec.kind == "sensor" else True
            period = period_ticks(spec.rate_hz, hz)
            slots[spec.name] = Slot(spec.name, comp, period, self._origins[spec.name], lambda: self.world.tick, lazy)
        for spec in cfg.sensors:
            slots[spec.name].check = self._reading_check(slots[spec.name])
        sensors = {s.name: slots[s.name] for s in cfg.sensors}
        actuators = {s.name: slots[s.name] for s in cfg.actuators}
        self.recoveries: dict[str, Member] = {}
        if cfg.behaviour is not None:
            self.behaviour = self._instantiate(cfg.behaviour)
        self.monitors = [self._member(spec) for spec in cfg.monitors]
        stepped, period = self.behaviour, period_ticks(cfg.behaviour.rate_hz, hz) if cfg.behaviour else 1
        if self.monitors:  # the task and its monitors, stepped as one, each at its own rate
            task = self._member(cfg.behaviour, self.behaviour) if cfg.behaviour else None
            from robokit.core.compose import Monitored

            self.recoveries = {name: self._member(spec) for name, spec in cfg.recoveries.items()}
            self._monitored = Monitored(task, self.monitors, self.world,
                                        {n: slot.component for n, slot in actuators.items()}, self.recoveries,
                                        self._tracer("monitors"))
            stepped, period = self._monitored, 1
        self.scheduler = TickScheduler(self.world, sensors, actuators, stepped, period,
                                       self._origins.get("behaviour", ""))
        self.readings = self.scheduler.readings
        for spec in cfg.sensors + cfg.actuators:
            self._setup(spec)
        if cfg.behaviour is not None:
            self._setup_tree(cfg.behaviour)
        for spec in cfg.monitors:
            self._setup(spec)
        if self.monitors:  # a spare of each monitor that pre-empts into a recovery, to watch it (guards keep guarding)
            self._monitored.watchers = {spec.name: self._fresh(spec) for spec in cfg.monitors
                                        if spec.action == "recover" and spec.watch_recovery}
        for spec in cfg.recoveries.values():
            if spec.name in self.recoveries:
                self._setup_tree(spec)
        if self.randomizer is not None:
            self.randomizer.apply_world(self.world)
        self._schedule_events()

    def _randomize(self, spec: Any, rng: Any = None) -> None:
        """Draw ``[randomize]`` (from its own child of the seed unless ``rng`` is given). Plugin settings are
        applied as each component is built, dropout when each sensor is, the world's draws once every component
        is set up (so a plugin that sets a body's dynamics, as the gripper sets finger friction, is randomised
        over what it set)."""
        from robokit.core.randomize import Randomizer, generator

        self.randomizer = Randomizer(spec, self.config)
        self.randomizer.draw(self.world, self.body_keys, generator(self.seed) if rng is None else rng)

    def _member(self, spec: ComponentSpec, instance: Any = None) -> Member:
        """A behaviour of a composition (a composite's child or a monitor), built unless ``instance`` is given."""
        from robokit.core.composites import Member

        comp = self._instantiate(spec) if instance is None else instance
        self._instances[spec.key] = comp
        return Member(spec.name, spec.type, comp, period_ticks(spec.rate_hz, self.world.physics_hz),
                      self._origins[spec.name], spec)

    def _setup_tree(self, spec: ComponentSpec) -> None:
        """Set up a behaviour; a composite's children first (each built, set up and handed to it)."""
        comp = self._instances[spec.key]
        if spec.children:
            comp.add_children([self._fresh(child) for child in spec.children])
            comp.rebuild = lambda member: self._fresh(member.spec)
        self._setup(spec)

    def _fresh(self, spec: ComponentSpec) -> Member:
        """A new, set-up instance of a composite's child (at build time, and for each attempt of a retry)."""
        member = self._member(spec)
        self._setup_tree(spec)
        return member

    def behaviour_specs(self) -> list[ComponentSpec]:
        """Every behaviour section of the config, the task's tree depth-first (children first), then monitors."""
        def walk(spec: ComponentSpec) -> list[ComponentSpec]:
            return [s for child in spec.children for s in walk(child)] + [spec]

        recoveries = [s for spec in self.config.recoveries.values() if spec.name in self.recoveries
                      for s in walk(spec)]
        return [*(walk(self.config.behaviour) if self.config.behaviour else []), *self.config.monitors, *recoveries]

    def monitor_results(self) -> dict[str, Any]:
        """Every monitor's outcome (``running`` while it runs), reason, ``action`` and own result, by name; the one
        that acted also has ``acted_at`` (sim s) and its ``recovery``. Empty with no monitors. The same as a
        finished run's ``result["monitors"]``, available at any tick."""
        return self._monitored.results() if self.monitors else {}

    def _instantiate(self, spec: ComponentSpec) -> Any:
        ptype = self.plugins.get(spec.kind, spec.type)
        self._origins[spec.name] = f"type {spec.type!r} from {ptype.origin}"
        params = spec.params if self.randomizer is None else self.randomizer.params_for(spec)
        try:
            comp = ptype.cls(spec.name, params)
        except Interrupted:
            raise
        except BaseException as exc:
            raise PluginError(f"{spec.key}: {spec.kind} type {spec.type!r} ({ptype.origin}) failed to build: "
                              f"{plugin_fault(exc)}", type_name=spec.type, distribution=ptype.origin) from exc
        if spec.kind != "behaviour":
            self.components[spec.name] = comp
        if spec.kind == "sensor" and self.randomizer is not None:
            self.randomizer.install_dropout(spec.name, comp, self.world, self.seed)
        self._instances.setdefault(spec.key, comp)
        return comp

    def _setup(self, spec: ComponentSpec) -> None:
        comp = self._instances[spec.key]
        rng = self.world.rng.spawn(1)[0]
        ctx = SetupContext(self.world, rng, spec.key, self.readings, self.components, self.config.base_dir,
                           self._tracer(spec.name), self.body_keys, run_dir=self.run_dir,
                           save_frames=self.save_frames)
        self._contexts[spec.key] = ctx
        provided = self.plugins.get(spec.kind, spec.type).provided()  # names a third-party type's distribution
        try:
            comp.setup(ctx)
        except ConfigError as exc:
            raise ConfigError(exc.message + provided, key=exc.key).within(spec.key, self.config.source) from None
        except UserError as exc:
            raise ConfigError(str(exc) + provided, key=spec.key, file=self.config.source) from None
        except Interrupted:
            raise
        except BaseException as exc:  # SystemExit and KeyboardInterrupt from a plugin are plugin faults too
            ptype = self.plugins.get(spec.kind, spec.type)
            raise PluginError(f"{spec.key}: {spec.kind} type {spec.type!r} ({ptype.origin}) raised during setup: "
                              f"{plugin_fault(exc)}", type_name=spec.type, distribution=ptype.origin) from exc

    def _reading_check(self, slot: Slot) -> Callable[[Slot], None]:
        """The check run after each reading a sensor computes: non-finite values are flagged (in the trace and the
        result's warnings), values that cannot be serialised end the run naming the sensor."""
        from robokit.core.reading_check import ReadingCheck, Unserialisable

        check = ReadingCheck(allow_inf=bool(getattr(slot.component, "allow_inf", False)))
        self._checks[slot.name] = check

        def after_read(slot: Slot) -> None:
            try:
                where = check(slot.value)
            except Unserialisable as exc:
                raise PluginError(f"sensor {slot.name!r} ({slot.origin}) returned a reading that cannot be "
                                  f"serialised: {exc} ({type(slot.value).__name__} from read())",
                                  type_name=slot.origin) from None
            if where is None:
                return
            flag = self.flags.get(slot.name)
            if flag is None:
                self.flags[slot.name] = {"count": 1, "first_tick": self.world.tick, "field": where}
                self._tracer(slot.name)("nonfinite", field=where)
            else:
                flag["count"] += 1

        return after_read

    def _tracer(self, source: str) -> Callable[..., None]:
        def trace(kind: str, **data: Any) -> None:
            record = {"tick": self.world.tick, "t": round(self.world.time, 6), "source": source, "kind": kind, **data}
            self.trace.append(record)
            for listener in self.trace_listeners:
                listener(record)

        return trace

    def _schedule_events(self) -> None:
        dt_ = self.world.time_step
        events = self.scheduler.events
        log = self._tracer("events")
        for ev in self.config.events:
            start = round(ev.at / dt_)
            if ev.type == "force":
                ticks = max(1, round(ev.duration / dt_))
                for k in range(start, start + ticks):
                    first = k == start
                    events.setdefault(k, []).append(self._event_action(ev, log if first else None))
            else:
                events.setdefault(start, []).append(self._event_action(ev, log))

    def _event_action(self, ev: Any, log: Callable[..., None] | None) -> Callable[[], None]:
        w = self.world

        def act() -> None:
            if not w.has_body(ev.body):
                return
            if ev.type == "force":
                w.apply_force(ev.body, ev.force)
            elif ev.type == "set_pose":
                orn = to_quaternion(ev.rpy_deg) if ev.rpy_deg is not None else None
                w.set_pose(ev.body, ev.position, orn)
            else:
                w.remove_body(ev.body)
            if log is not None:
                log("event", type=ev.type, body=ev.body)

        return act

    def add_monitor(self, monitor: Any) -> None:
        """Put an observer in the loop: ``monitor.sample(tick)`` runs every ``monitor.period`` ticks (0 = never),
        at the start of the tick, before the sensors (see :mod:`robokit.core.scheduler`)."""
        if monitor.period:
            self.scheduler.monitors.append(monitor)

    def preflight(self) -> list[ConfigError]:
        """What can be checked without running: the core's checks (bodies spawned overlapping), then every
        component's and the behaviour's ``preflight(ctx)``. Each problem is a ConfigError naming file and key.
        """
        from robokit.core.preflight import composition_problems, overlapping_bodies

        problems = overlapping_bodies(self.world, self.body_keys)
        problems += composition_problems(self.behaviour_specs(), self._instances)
        specs = list(self.config.sensors + self.config.actuators) + self.behaviour_specs()
        for spec in specs:
            comp = self._instances[spec.key]
            hook = getattr(comp, "preflight", None)
            if hook is None:
                continue
            try:
                found = list(hook(self._contexts[spec.key]) or ())
            except UserError as exc:
                found = [exc if isinstance(exc, ConfigError) else ConfigError(str(exc), key=spec.key)]
            except Exception as exc:
                ptype = self.plugins.get(spec.kind, spec.type)
                raise PluginError(f"{spec.key}: {spec.kind} type {spec.type!r} ({ptype.origin}) raised during "
                                  f"preflight: {type(exc).__name__}: {exc}", type_name=spec.type,
                                  distribution=ptype.origin) from exc
            problems.extend(found)
        return [p.within(file=self.config.source) for p in problems]

    # ----------------------------------------------------------------- stepping
    @property
    def outcome(self) -> Any:
        """The behaviour's outcome so far (None while it runs or when there is no behaviour)."""
        return self.behaviour.outcome if self.behaviour is not None else None

    def step(self, n: int = 1) -> None:
        """Run ``n`` ticks (ignores outcomes and time limits: tests decide when to stop)."""
        for _ in range(n):
            self.scheduler.tick()

    def run_until(self, predicate: Callable[[Simulation], bool], max_ticks: int) -> bool:
        """Step until ``predicate(sim)`` is true (checked before each tick); False if ``max_ticks`` ran out."""
        for _ in range(max_ticks):
            if predicate(self):
                return True
            self.scheduler.tick()
        return bool(predicate(self))

    def run(self, *, max_time: float | None = None, max_wall: float | None = None,
            wall_clock: Callable[[], float] = time.perf_counter) -> RunResult:
        """Run until the behaviour ends, ``max_time`` sim seconds pass, the wall-clock budget (``max_wall``, default
        ``world.max_wall_time``) runs out, or SIGINT/SIGTERM; return the RunResult.

        A plugin that raises ends the run with outcome ``error``; the behaviour's partial result is kept, and so it
        is when the run is interrupted (outcome ``aborted``, ``interrupted`` true) or over its wall-clock budget
        (outcome ``aborted``, the reason names the component that took the most wall time).
        """
        limit = self.config.world.max_time if max_time is None else max_time
        budget = self.config.world.max_wall_time if max_wall is None else max_wall
        max_ticks = round(limit / self.world.time_step)
        started = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
        t0 = wall_clock()
        outcome, reason = "aborted", ""
        pace = self.world.gui and self.config.world.realtime
        timing = None
        if budget is not None:
            from robokit.core.walltime import WallTiming

            timing = WallTiming(self.scheduler, wall_clock)
        with StopGuard.ensure() as guard, guard.soft(self.interrupt):
            if guard.signalled:  # Ctrl-C arrived while the guard was soft elsewhere: stop at once
                self.interrupt(guard.signal or "SIGINT")
            if budget is not None:
                guard.watchdog(budget, self._expire_wall, "max_wall_time")
            try:
                self.plugins.call("robokit_run_start", simulation=self)
                if self.randomizer is not None:  # traced here, where the run record listens already
                    self._tracer("randomize")("drawn", **self.randomizer.drawn)
                if pace:
                    self.scheduler.start_pacing()
                world, behaviour, tick = self.world, self.behaviour, self.scheduler.tick
                while world.tick < max_ticks and (behaviour is None or behaviour.outcome is None) and not self._halt:
                    tick()
                    if pace:
                        self.scheduler.pace()
            except PluginError as exc:
                self.error = exc
                outcome, reason = "error", str(exc)
                self._tracer("run")("error", reason=reason)  # the trace ends with what stopped the run
            except Interrupted as exc:
                if exc.reason == "max_wall_time":
                    self._wall_expired = True
                else:
                    self.interrupt(exc.reason)
            except Exception as exc:  # noqa: BLE001 - a bug in robokit: keep the result, say where the traceback is
                self.error = exc
                outcome, reason = "error", f"internal error in robokit: {plugin_fault(exc)}"
                self._tracer("run")("error", reason=reason)
            finally:
                if timing is not None:
                    timing.restore()
        if outcome != "error":
            outcome, reason = self._ending(limit, budget, timing)
        goal: dict[str, Any] | None = None
        if outcome != "error" and self.behaviour is not None:
            try:
                outcome, reason, goal = self._check_goal(outcome, reason)
            except PluginError as exc:
                self.error = exc
                outcome, reason = "error", str(exc)
            except Interrupted as exc:  # a second Ctrl-C while checking the goal: keep the result without it
                self.interrupt(exc.reason)
        behaviour_result = self._behaviour_result()
        if goal is not None:
            behaviour_result["goal"] = goal
        if self.monitors:
            behaviour_result["monitors"] = self._monitored.results()
        if self.randomizer is not None:
            behaviour_result["randomize"] = self.randomizer.drawn
        result = RunResult(
            run_id=self.run_id,
            robokit_version=__version__,
            config=self.config.source,
            behaviour=self.config.behaviour.type if self.config.behaviour else None,
            seed=self.seed,
            outcome=outcome,
            reason=reason,
            ticks=self.world.tick,
            sim_time=round(self.world.time, 6),
            wall_time=round(wall_clock() - t0, 6),
            started_at=started,
            result=behaviour_result,
            interrupted=self.interrupted and self.outcome is None,
            warnings=self._warnings(),
            engine=self.world.engine,
            engine_version=self.world.engine_version,
        )
        try:
            self.plugins.call("robokit_run_end", simulation=self, result=result)
        except PluginError as exc:  # the result survives a faulty run_end hook
            if result.outcome != "error":
                self.error = exc
                result.outcome, result.reason = "error", str(exc)
        return result

    def _check_goal(self, outcome: str, reason: str) -> tuple[str, str, dict[str, Any] | None]:
        """Evaluate the behaviour's goal on the world: for a run the behaviour ended, the world decides (met:
        ``succeeded``, not met: ``failed``, the reason says why and what the behaviour claimed).

        Returns the (possibly changed) outcome and reason, and the goal's record for the result (None if the
        behaviour states no goal).
        """
        hook = getattr(self.behaviour, "check_goal", None)
        if hook is None:
            return outcome, reason, None
        try:
            check = hook(self.world)
        except Interrupted:
            raise
        except BaseException as exc:
            spec = self.config.behaviour
            assert spec is not None
            ptype = self.plugins.get("behaviour", spec.type)
            raise PluginError(f"behaviour type {spec.type!r} ({ptype.origin}) raised in check_goal: "
                              f"{plugin_fault(exc)}", type_name=spec.type, distribution=ptype.origin) from exc
        if check is None:
            return outcome, reason, None
        record = {"met": bool(check.met), "reason": check.reason, **dict(check.details)}
        self._tracer("behaviour")("goal", met=record["met"], reason=check.reason)
        claimed = f" (the behaviour reported {outcome}: {reason})" if reason else f" (the behaviour reported {outcome})"
        if outcome not in ("succeeded", "failed"):  # stopped by a limit or a signal: not judged, the goal recorded
            return outcome, f"{reason}; goal not met: {check.reason}" if not check.met else reason, record
        if check.met and outcome == "failed":  # the world's verdict (docs/outcomes.md); the claim stays on record
            record["claimed"] = {"outcome": outcome, "reason": reason}
            return "succeeded", f"goal met: {check.reason}{claimed}", record
        if not check.met:
            record["claimed"] = {"outcome": outcome, "reason": reason}
            return "failed", f"goal not met: {check.reason}{claimed}", record
        return outcome, reason, record

    def _ending(self, limit: float, budget: float | None, timing: WallTiming | None) -> tuple[str, str]:
        """Outcome and reason of a run that did not end in an error."""
        if self.outcome is not None:
            return self.outcome.status, self.outcome.reason
        if self.interrupted:
            return "aborted", f"interrupted by {self._stop_reason} at t = {self.world.time:.3f} s"
        if self._wall_expired:
            slow = timing.slowest() if timing is not None else ""
            return "aborted", (f"max_wall_time {budget:g} s (wall clock) reached at t = {self.world.time:.3f} s"
                               + (f"; slowest: {slow}" if slow else ""))
        if self.behaviour is None:  # a scene with no behaviour just runs for max_time
            return "succeeded", f"no behaviour: simulated {limit:g} s"
        if getattr(self.behaviour, "open_ended", False):  # e.g. teleop: runs until stopped
            return "succeeded", f"open-ended behaviour ran for max_time {limit:g} s"
        return "aborted", f"max_time {limit:g} s reached before the behaviour finished"

    def _expire_wall(self) -> None:
        """The watchdog's call (from its thread): stop at the next tick boundary."""
        self._wall_expired = True
        self._halt = True

    def _warnings(self) -> list[str]:
        lines = []
        for name, flag in self.flags.items():
            checked = self._checks[name].checked
            lines.append(f"sensor {name!r} ({self._origins.get(name, '?')}) returned non-finite values in "
                         f"{flag['count']} of {checked} reading(s) checked; first at tick {flag['first_tick']} "
                         f"({flag['field']})")
        return lines

    def _behaviour_result(self) -> dict[str, Any]:
        if self.behaviour is None:
            return {}
        try:
            return dict(self.behaviour.result())
        except Interrupted:
            raise
        except BaseException as exc:  # noqa: BLE001 - the run's result must survive a faulty behaviour
            return {"result_error": plugin_fault(exc)}

    def interrupt(self, reason: str = "request") -> None:
        """Ask the loop to stop at the next tick boundary (what Ctrl-C does)."""
        self.interrupted = True
        self._stop_reason = reason
        self._halt = True

    # ----------------------------------------------------------------- lifetime
    def close(self) -> None:
        """Close every component, then the World. Safe to call twice."""
        watchers = getattr(getattr(self, "_monitored", None), "watchers", {})
        monitors = [m.behaviour for m in [*self.monitors, *getattr(self, "recoveries", {}).values(),
                                          *watchers.values()]]
        for comp in list(self.components.values()) + ([self.behaviour] if self.behaviour else []) + monitors:
            try:
                comp.close()
            except Interrupted:
                raise
            except BaseException:  # noqa: BLE001, S110 - closing must reach the world
                pass
        self.components.clear()
        self.world.close()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _as_config_error(exc: UserError, section: str, source: str) -> ConfigError:
    if isinstance(exc, ConfigError):
        return exc.within(file=source)
    return ConfigError(str(exc), key=section, file=source)


def spawn_bodies(world: World, cfg: Config, keys: dict[str, str] | None = None) -> None:
    """Create every body and robot of a config: fixed ones first, then region-scattered ones, seeded.

    ``keys``, if given, receives the config key of every body spawned (``red_0`` -> ``bodies.red``).
    """
    keys = {} if keys is None else keys
    groups = {**{n: ("bodies", b) for n, b in cfg.bodies.items()}, **{n: ("robots", b) for n, b in cfg.robots.items()}}
    for name, (section, body) in groups.items():
        if body.region is None:
            _spawn_one(world, f"{section}.{name}", name, body, body.position or (0.0, 0.0, 0.0))
            keys[name] = f"{section}.{name}"
    for region_name, region in cfg.regions.items():
        members = [(n, s, b) for n, (s, b) in groups.items() if b.region == region_name]
        total = sum(b.count for _, _, b in members)
        if total == 0:
            continue
        for avoided in region.avoid:
            if not world.has_body(avoided):
                raise ConfigError(f"unknown body {avoided!r} (bodies placed in regions cannot be avoided)",
                                  key=f"regions.{region_name}.avoid")
        boxes = [world.body_aabb(a) for a in region.avoid]
        try:
            points = iter(world.sample_positions(total, region.low, region.high, min_spacing=region.min_spacing,
                                                 avoid=boxes, clearance=region.clearance))
        except UserError as exc:
            raise ConfigError(str(exc), key=f"regions.{region_name}") from None
        for name, section, body in members:
            for i in range(body.count):
                x, y = next(points)
                label = name if body.count == 1 else f"{name}_{i}"
                _spawn_one(world, f"{section}.{name}", label, body, (x, y, region.z))
                keys[label] = f"{section}.{name}"
    for name, (section, body) in groups.items():
        if body.mount is not None:
            _mount(world, f"{section}.{name}.mount", name, body.mount)


def _mount(world: World, key: str, name: str, mount: Any) -> None:
    """Fix a body on another body's link (a gripper on a flange), as its config's ``mount`` says."""
    if not world.has_body(mount.body):
        raise ConfigError(f"unknown body {mount.body!r}; bodies: {', '.join(world.body_names)}", key=f"{key}.body")
    if mount.body == name:
        raise ConfigError("a body cannot be mounted on itself", key=f"{key}.body")
    try:
        link = world.link(mount.body, mount.link)
    except UserError as exc:
        raise ConfigError(str(exc), key=f"{key}.link") from None
    world.mount(name, mount.body, link, position=mount.position, orientation=to_quaternion(mount.rpy_deg),
                max_force=mount.max_force)


def _orientation(world: World, body: BodyConfig) -> tuple[float, float, float, float]:
    if body.yaw_deg_range is not None:
        roll, pitch, _ = body.rpy_deg or (0.0, 0.0, 0.0)
        yaw = float(world.rng.uniform(*body.yaw_deg_range))
        return to_quaternion((roll, pitch, yaw))
    return to_quaternion(body.rpy_deg, body.quaternion)


def _urdf_path(world: World, body: BodyConfig) -> str:
    """The URDF a body loads: a xacro file (``robot.urdf.xacro``) is expanded first, with its ``xacro_args``."""
    assert body.urdf is not None
    if not body.urdf.lower().endswith(".xacro"):
        return body.urdf
    from robokit.robot.expand import expand_xacro

    return str(expand_xacro(world.resolve_urdf(body.urdf), body.xacro_args))


def _spawn_one(world: World, key: str, name: str, body: BodyConfig, position: Any) -> None:
    orn = _orientation(world, body)
    pos = tuple(float(v) for v in np.asarray(position, float))
    try:
        if body.shape is not None:
            world.add_primitive(
                name, body.shape, size=body.size, radius=body.radius, height=body.height, mass=body.mass,
                position=pos, orientation=orn, rgba=body.rgba, lateral_friction=body.lateral_friction,
                rolling_friction=body.rolling_friction, spinning_friction=body.spinning_friction,
                restitution=body.restitution, linear_damping=body.linear_damping,
                angular_damping=body.angular_damping, mesh_collision=body.collision == "mesh",
            )
        else:
            if body.urdf is not None:
                world.load_urdf(name, _urdf_path(world, body), position=pos, orientation=orn,
                                fixed_base=body.fixed_base,
                                scale=body.scale, self_collision=body.self_collision)
            else:
                kind, path = ("sdf", body.sdf) if body.sdf is not None else ("mjcf", body.mjcf)
                assert path is not None
                world.load_model(name, path, kind, position=pos, orientation=orn, fixed_base=body.fixed_base,
                                 scale=body.scale)
            world.set_dynamics(name, lateral_friction=body.lateral_friction, restitution=body.restitution,
                               rolling_friction=body.rolling_friction, spinning_friction=body.spinning_friction,
                               linear_damping=body.linear_damping, angular_damping=body.angular_damping)
            for joint_name, value in body.joint_positions.items():
                try:
                    info = world.joint(name, joint_name)
                except UserError as exc:
                    raise ConfigError(str(exc), key=f"{key}.joint_positions.{joint_name}") from None
                world.reset_joint(world.body(name), info.index, value)
    except ConfigError:
        raise
    except UserError as exc:
        raise ConfigError(str(exc), key=key) from None


def build(
    config: str | Path | dict[str, Any],
    *,
    plugins: Plugins | None = None,
    extra_plugins: tuple[object, ...] = (),
    overrides: dict[str, Any] | None = None,
    gui: bool | None = None,
    seed: int | None = None,
    base_dir: str | Path | None = None,
) -> Simulation:
    """Build a Simulation from a TOML path or a config dict (loading plugins unless given)."""
    from robokit.config import build_config, load_config, set_dotted
    from robokit.plugin_api.plugins import load_plugins

    plugins = plugins or load_plugins(extra_plugins)
    if isinstance(config, dict):
        raw = copy.deepcopy(config)
        for dotted, value in (overrides or {}).items():
            set_dotted(raw, dotted, value)
        cfg = build_config(raw, plugins, base_dir=Path(base_dir) if base_dir else Path.cwd())
    else:
        cfg = load_config(config, plugins, overrides)
    return Simulation(cfg, plugins, gui=gui, seed=seed)
