"""Conformance checks for sensor and actuator plugin types: does a type keep the plugin contract?

Use them through :mod:`robokit.testing`::

    from robokit.testing import check_sensor

    def test_imu_conforms():
        check_sensor("imu")          # builds the type from its class attribute ``example``

A check builds the type from a minimal scene and config section — the class attribute ``example`` (see
:attr:`robokit.components.Sensor.example`), or ``config=`` / ``scene=`` given to the check — in fresh DIRECT-mode
simulations, and verifies, in order:

1. **declares**: a config schema (a :class:`robokit.config.Schema` subclass, so unknown keys are rejected), a
   one-line description (the class docstring) and a ``reading_type`` other than ``object``;
2. **builds** from the minimal config (validation, ``__init__`` and ``setup``);
3. **rate**: a sensor's reading is computed once per due tick at most (lazy sensors only when read, non-lazy ones
   on every due tick); an actuator's ``update()`` runs exactly on its due ticks;
4. **shape**: every reading is an instance of ``reading_type``;
5. **determinism**: two fresh simulations with the same seed give equal readings, tick by tick; sensors: a third,
   where ``read()`` is also called out of band, gives them too (noise drawn per *tick*, ``ctx.tick_rng()``, not per
   read: a test or a monitor that looks at a sensor must not change the run);
6. **close**: after ``close()`` the world holds as many bodies and constraints as the same scene without the
   component, a second ``close()`` does not raise, and the World then disconnects;
7. actuators only: a bad command (``object()``) is refused with ``ValueError`` or ``TypeError``.

A failed check raises :class:`ConformanceError` (an ``AssertionError``) whose message names the type, its
distribution and the check.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel

from robokit.checks.budget import DEFAULT_BUDGET, Beat, Overrun, run_bounded
from robokit.config import Schema, build_config
from robokit.config.sections import Section
from robokit.core.simulation import Simulation
from robokit.errors import ConfigError, PluginError, UserError
from robokit.plugin_api.plugins import Plugins, PluginType, load_plugins

DEFAULT_TICKS = 48
"""Ticks each simulation of a check runs (an example may set ``"ticks"``)."""
EXAMPLE_KEYS = ("config", "commands", "ticks")
"""Keys of an ``example`` that are not config sections."""
_UNKNOWN_KEY = "zz_conformance_unknown_key"


class ConformanceError(AssertionError):
    """A plugin type broke the plugin contract; the message names the type, its origin and the check."""


class PassedChecks:
    """The text every conformance report prints: a head line naming the type and its origin, then one ``ok`` line
    per check passed (shared by :class:`ConformanceReport` and ``BehaviourReport``)."""

    kind: str
    type_name: str
    origin: str
    checks: list[str]

    def __str__(self) -> str:
        head = f"{self.kind} {self.type_name!r} ({self.origin}) conforms:"
        return "\n".join([head, *(f"  ok  {line}" for line in self.checks)])


@dataclass
class ConformanceReport(PassedChecks):
    """What a passed check verified.

    Attributes:
        kind: ``"sensor"`` or ``"actuator"``.
        type_name: The type checked.
        origin: Its distribution and version.
        period: Ticks between runs of the component in the check.
        ticks: Ticks each simulation ran.
        computed: Sensors: readings computed in the first simulation; actuators: ``update()`` calls.
        checks: One line per check passed.
    """

    kind: str
    type_name: str
    origin: str
    period: int = 1
    ticks: int = DEFAULT_TICKS
    computed: int = 0
    checks: list[str] = field(default_factory=list)


def check_sensor(
    type_name: str,
    config: Mapping[str, Any] | None = None,
    *,
    scene: Mapping[str, Any] | None = None,
    seed: int = 0,
    ticks: int | None = None,
    rate_hz: float | None = None,
    extra_plugins: Iterable[object] = (),
    budget: float = DEFAULT_BUDGET,
) -> ConformanceReport:
    """Check that a registered sensor type keeps the plugin contract (see the module docstring).

    Args:
        type_name: The sensor type, as in ``type = "..."``.
        config: The type's config section without ``type`` (default: ``example["config"]``).
        scene: Other config sections (``bodies``, ``robots``, ``world``, ``sensors``, ``actuators``, ``regions``);
            default: the rest of the type's ``example``, or a ground plane alone.
        seed: The world seed of both simulations.
        ticks: Ticks per simulation (default: ``example["ticks"]`` or :data:`DEFAULT_TICKS`).
        rate_hz: The sensor's rate when its config sets none (default: the physics rate / 4).
        extra_plugins: Plugin objects to register besides the installed entry points.
        budget: Wall-clock seconds one plugin call may take (a build, one tick with its reads, a close); a call
            that never returns fails the check naming the type and the call.

    Raises:
        ConformanceError: A check failed.
    """
    return _Check("sensor", type_name, config, scene, None, seed, ticks, rate_hz, extra_plugins, budget).run()


def check_actuator(
    type_name: str,
    config: Mapping[str, Any] | None = None,
    *,
    scene: Mapping[str, Any] | None = None,
    commands: Sequence[tuple[int, Any]] | None = None,
    seed: int = 0,
    ticks: int | None = None,
    rate_hz: float | None = None,
    extra_plugins: Iterable[object] = (),
    budget: float = DEFAULT_BUDGET,
) -> ConformanceReport:
    """Check that a registered actuator type keeps the plugin contract (see the module docstring).

    Args are those of :func:`check_sensor`, plus ``commands``: ``(tick, command)`` pairs sent to the actuator
    before that tick's update (default: ``example["commands"]``).

    Raises:
        ConformanceError: A check failed.
    """
    return _Check("actuator", type_name, config, scene, commands, seed, ticks, rate_hz, extra_plugins, budget).run()


class _Check:
    """One conformance check of one type: three small simulations (two for determinism, one baseline)."""

    def __init__(self, kind: str, type_name: str, config: Mapping[str, Any] | None, scene: Mapping[str, Any] | None,
                 commands: Sequence[tuple[int, Any]] | None, seed: int, ticks: int | None, rate_hz: float | None,
                 extra_plugins: Iterable[object], budget: float = DEFAULT_BUDGET) -> None:
        self.kind, self.type_name, self.seed, self.budget = kind, type_name, seed, budget
        self.plugins: Plugins = load_plugins(tuple(extra_plugins))
        try:
            self.ptype: PluginType = self.plugins.get(kind, type_name)
        except UserError as exc:
            raise ConformanceError(f"{kind} type {type_name!r}: not registered: {exc}") from None
        self.report = ConformanceReport(kind, type_name, self.ptype.origin)
        example = self._example(config, scene)
        self.commands = sorted(commands if commands is not None else example.get("commands", ()),
                               key=lambda pair: pair[0])
        self.report.ticks = self.ticks = int(ticks or example.get("ticks") or DEFAULT_TICKS)
        self.name = type_name
        self.raw = self._raw_config(example, rate_hz)
        self.base_dir = _module_dir(self.ptype.cls)

    def fail(self, check: str, message: str) -> ConformanceError:
        return ConformanceError(f"{self.kind} type {self.type_name!r} ({self.ptype.origin}): {check}: {message}")

    def passed(self, line: str) -> None:
        self.report.checks.append(line)

    # ------------------------------------------------------------------ inputs
    def _example(self, config: Mapping[str, Any] | None, scene: Mapping[str, Any] | None) -> dict[str, Any]:
        declared = getattr(self.ptype.cls, "example", None)
        if declared is None and config is None:
            raise self.fail("example", f"{self.ptype.cls.__name__} declares no `example` (a minimal scene and "
                            "config section, see docs/plugins.md) and no config= was given")
        example = copy.deepcopy(dict(declared or {}))
        if config is not None:
            example["config"] = copy.deepcopy(dict(config))
        if scene is not None:
            example = {**{k: v for k, v in example.items() if k in EXAMPLE_KEYS}, **copy.deepcopy(dict(scene))}
        if not any(k not in EXAMPLE_KEYS for k in example):
            example["bodies"] = {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}}
        return example

    def _raw_config(self, example: dict[str, Any], rate_hz: float | None) -> dict[str, Any]:
        raw = {k: v for k, v in example.items() if k not in EXAMPLE_KEYS}
        section = f"{self.kind}s"
        raw[section] = dict(raw.get(section, {}))
        if self.name in raw[section]:
            self.name = f"{self.type_name}_under_test"
        own = {"type": self.type_name, **dict(example.get("config", {}))}
        if "rate_hz" not in own:
            time_step = float(raw.get("world", {}).get("time_step", 1.0 / 240.0))
            own["rate_hz"] = rate_hz if rate_hz is not None else 1.0 / time_step / 4
        raw[section][self.name] = own
        return raw

    # ------------------------------------------------------------------ checks
    def run(self) -> ConformanceReport:
        self._check_declarations()
        self._check_unknown_key()
        sim_a = self._build("builds")
        try:
            values_a = self._drive(sim_a)
            self.passed(f"builds from its example and runs {self.ticks} ticks")
            self._check_rate(sim_a, values_a)
            self._check_shape(values_a)
            self._check_determinism(values_a)
            if self.kind == "actuator":
                self._check_bad_command(sim_a)
            self._check_close(sim_a)
        finally:
            sim_a.close()
        if sim_a.world.client is not None:
            raise self.fail("close", "the World is still connected after Simulation.close()")
        return self.report

    def _check_declarations(self) -> None:
        schema, cls = self.ptype.schema, self.ptype.cls
        problem = declaration_problem(self.ptype)
        if problem is not None:
            raise self.fail(*problem)
        reading_type = getattr(cls, "reading_type", object)
        if not isinstance(reading_type, type) or reading_type is object:
            raise self.fail("reading_type", f"{cls.__name__}.reading_type is {reading_type!r}; declare the type "
                            "every reading is an instance of")
        self.passed(f"declares schema {schema_kind(schema)}, reading_type "
                    f"{reading_type.__name__}, description {self.ptype.description!r}")

    def _check_unknown_key(self) -> None:
        raw = copy.deepcopy(self.raw)
        raw[f"{self.kind}s"][self.name][_UNKNOWN_KEY] = 1
        try:
            build_config(raw, self.plugins, base_dir=self.base_dir)
        except ConfigError as exc:
            if _UNKNOWN_KEY in str(exc):
                self.passed("rejects unknown config keys")
                return
            raise self.fail("schema", f"the example config does not validate: {exc}") from None
        raise self.fail("schema", f"an unknown key {_UNKNOWN_KEY!r} was accepted; subclass robokit.config.Schema "
                        "(unknown keys forbidden)")

    def bounded(self, work: Any) -> Any:
        """Run ``work(beat)`` with the wall-clock budget per call; an overrun fails the check naming the call."""
        try:
            return run_bounded(work, self.budget)
        except Overrun as exc:
            raise self.fail("budget", f"{exc}: a plugin call must return (measure now, wait in sim time)") from None

    def _build(self, check: str, raw: Mapping[str, Any] | None = None) -> Simulation:
        def build(beat: Beat) -> Simulation:
            beat("building the example (__init__, setup)")
            try:
                cfg = build_config(raw or self.raw, self.plugins, base_dir=self.base_dir)
                return Simulation(cfg, self.plugins, gui=False, seed=self.seed)
            except (UserError, PluginError) as exc:
                raise self.fail(check, f"the example does not build: {exc}") from None

        return self.bounded(build)  # type: ignore[no-any-return]

    def _drive(self, sim: Simulation, extra_reads: list[int] | None = None) -> list[Any]:
        """Step ``ticks`` ticks, sending commands and reading the component after every tick (with
        ``extra_reads = [n]``, also calling ``read()`` directly, before the loop's read, on the first n due ticks);
        each tick within the wall-clock budget."""
        return self.bounded(lambda beat: self._drive_ticks(sim, beat, extra_reads))  # type: ignore[no-any-return]

    def _drive_ticks(self, sim: Simulation, beat: Beat, extra_reads: list[int] | None) -> list[Any]:
        slot = sim.scheduler.slots[self.name]
        comp = slot.component
        self.update_ticks: list[int] = []
        if self.kind == "actuator":
            update = comp.update

            def counted() -> None:
                self.update_ticks.append(sim.world.tick)
                update()

            comp.update = counted
        values, self.stamps = [], []
        try:
            for k in range(self.ticks):
                beat(f"tick {k} (command, update, read)")
                for cmd in [cmd for tick, cmd in self.commands if tick == k]:
                    comp.command(cmd)
                sim.step(1)
                if extra_reads and extra_reads[0] > 0 and sim.scheduler.slots[self.name].stale:
                    extra_reads[0] -= 1
                    comp.read()  # out of band: the loop does not see this value
                values.append(sim.readings[self.name])
                self.stamps.append(sim.readings.stamp(self.name))
        except Exception as exc:  # noqa: BLE001 - report any failure as a broken contract
            raise self.fail("run", f"raised at tick {sim.world.tick}: {type(exc).__name__}: {exc}") from exc
        self.computed = sim.readings.computed(self.name)
        return values

    def _check_rate(self, sim: Simulation, values: list[Any]) -> None:
        slot = sim.scheduler.slots[self.name]
        period, n = slot.period, self.ticks
        self.report.period = period
        due = [k for k in range(n) if k % period == 0]
        if self.kind == "actuator":
            if self.update_ticks != due:
                raise self.fail("rate", f"update() ran at ticks {self.update_ticks[:12]}, expected its due ticks "
                                f"{due[:12]} (every {period} ticks)")
            self.report.computed = len(self.update_ticks)
            self.passed(f"update() runs exactly on its due ticks (every {period} ticks, {len(due)} times)")
            return
        if self.computed != len(due):
            raise self.fail("rate", f"reading computed {self.computed} times in {n} ticks read every tick, expected "
                            f"{len(due)} (once per due tick, every {period} ticks)")
        for k in range(1, n):
            changed = self.stamps[k] != self.stamps[k - 1] or values[k] is not values[k - 1]
            if changed != (k % period == 0):
                raise self.fail("rate", f"reading {'changed' if changed else 'did not change'} after tick {k}; "
                                f"it is due every {period} ticks")
        self.report.computed = self.computed
        self.passed(f"reading computed only when due (every {period} ticks, {self.computed} times in {n})")

    def _check_shape(self, values: list[Any]) -> None:
        reading_type: type = getattr(self.ptype.cls, "reading_type", object)
        for k, value in enumerate(values):
            if not isinstance(value, reading_type):
                raise self.fail("shape", f"reading after tick {k} is a {type(value).__name__}, declared "
                                f"reading_type is {reading_type.__name__}")
        self.passed(f"every reading is a {reading_type.__name__}")

    def _check_determinism(self, values_a: list[Any]) -> None:
        sim_b = self._build("determinism")
        try:
            values_b = self._drive(sim_b)
            for k, (a, b) in enumerate(zip(values_a, values_b, strict=True)):
                diff = first_difference(a, b)
                if diff is not None:
                    raise self.fail("determinism", f"same seed {self.seed}, reading after tick {k} differs "
                                    f"between two fresh simulations at {diff}")
            self.passed(f"deterministic: two fresh simulations with seed {self.seed} give equal readings")
            if self.kind == "sensor":
                self._check_lazy(sim_b)
        finally:
            sim_b.close()
        if self.kind == "sensor":
            self._check_extra_reads(values_a)

    def _check_extra_reads(self, values_a: list[Any]) -> None:
        """A third simulation where ``read()`` is also called out of band on the first due ticks: the readings the
        loop sees must not change (noise drawn per read from ``ctx.rng`` would: use ``ctx.tick_rng()``)."""
        sim_c = self._build("extra reads")
        try:
            extra = [4]  # out-of-band reads left (a few suffice; a camera renders each time)
            values_c = self._drive(sim_c, extra_reads=extra)
            for k, (a, c) in enumerate(zip(values_a, values_c, strict=True)):
                diff = first_difference(a, c)
                if diff is not None:
                    raise self.fail("extra reads", f"reading after tick {k} changed at {diff} because read() was "
                                    "called once more before it: draw per-reading noise from ctx.tick_rng(), "
                                    "not ctx.rng")
            self.passed("extra read() calls do not change later readings (noise per tick, not per read)")
        finally:
            sim_c.close()

    def _check_lazy(self, sim: Simulation) -> None:
        slot = sim.scheduler.slots[self.name]
        before = slot.computed
        sim.step(2 * slot.period)
        extra = slot.computed - before
        expected = 0 if slot.lazy else 2
        if extra != expected:
            what = "lazy (computed only when read)" if slot.lazy else "non-lazy (computed on every due tick)"
            raise self.fail("rate", f"{what}, but computed {extra} times in two unread periods")
        self.passed("computed only when read (lazy)" if slot.lazy else "computed on every due tick (lazy = False)")

    def _check_bad_command(self, sim: Simulation) -> None:
        comp = sim.scheduler.slots[self.name].component
        try:
            comp.command(object())
        except (ValueError, TypeError):
            self.passed("refuses a bad command with ValueError/TypeError")
            return
        except Exception as exc:  # noqa: BLE001
            raise self.fail("command", f"command(object()) raised {type(exc).__name__}: {exc}; raise ValueError "
                            "with a clear message") from None
        raise self.fail("command", "command(object()) was accepted; raise ValueError for a bad command")

    def _check_close(self, sim: Simulation) -> None:
        baseline, closing = self._baseline()
        comps = [sim.scheduler.slots[n].component for n in closing(sim)]
        for attempt in ("close()", "a second close()"):
            for comp in comps:
                try:
                    comp.close()
                except Exception as exc:  # noqa: BLE001
                    raise self.fail("close", f"{attempt} raised {type(exc).__name__}: {exc}") from exc
        client = sim.world.client
        held = {"bodies": client.getNumBodies(), "constraints": client.getNumConstraints()}
        for what, count in held.items():
            if count != baseline[what]:
                raise self.fail("close", f"{count} {what} in the world after close(), {baseline[what]} in the same "
                                f"scene without the {self.kind}: remove what setup() created")
        if self.kind == "sensor":
            sim.world.step()  # one physics step with the sensor closed: what it switched on shows now
            left = _left_on(sim.world, baseline["state"])
            if left:
                raise self.fail("close", f"after close() {left}; a sensor switches off what it switched on")
        self.passed("close() releases its bodies and constraints" + (" and switches off what it switched on "
                    "(joint force-torque sensors, engine parameters, dynamics)" if self.kind == "sensor" else "")
                    + "; a second close() is safe")

    def _baseline(self) -> tuple[dict[str, Any], Any]:
        """Bodies and constraints of the scene without the component (or without any component)."""
        raw = copy.deepcopy(self.raw)
        del raw[f"{self.kind}s"][self.name]
        try:
            cfg = build_config(raw, self.plugins, base_dir=self.base_dir)
            sim = Simulation(cfg, self.plugins, gui=False, seed=self.seed)
            closing = lambda s: [self.name]  # noqa: E731
        except (UserError, PluginError):  # a helper needs the component: compare with the bare scene
            bare = {k: v for k, v in raw.items() if k not in ("sensors", "actuators")}
            sim = Simulation(build_config(bare, self.plugins, base_dir=self.base_dir), self.plugins, gui=False,
                             seed=self.seed)
            closing = lambda s: list(s.scheduler.slots)  # noqa: E731
        with sim:
            client = sim.world.client
            counts: dict[str, Any] = {"bodies": client.getNumBodies(), "constraints": client.getNumConstraints()}
            sim.world.step()
            counts["state"] = _engine_state(sim.world)
            return counts, closing


def _engine_state(world: Any) -> dict[str, Any]:
    """What a sensor may switch on in the physics engine: joints whose force-torque sensor measures (non-zero
    reaction after a step), the engine's parameters, and every link's dynamics, by body and link name."""
    c = world.client
    measuring, dynamics = set(), {}
    for name in world.body_names:
        bid = world.body(name)
        joints = c.getNumJoints(bid)
        for j in range(joints):
            if any(v != 0.0 for v in c.getJointState(bid, j)[2]):
                measuring.add(f"{name}/{c.getJointInfo(bid, j)[1].decode()}")
        for link in range(-1, joints):
            dynamics[(name, link)] = c.getDynamicsInfo(bid, link)
    return {"measuring": measuring, "parameters": c.getPhysicsEngineParameters(), "dynamics": dynamics}


def _left_on(world: Any, baseline: dict[str, Any]) -> str:
    """What differs from the scene without the sensor ("" when nothing)."""
    now = _engine_state(world)
    extra = sorted(now["measuring"] - baseline["measuring"])
    if extra:
        return f"the force-torque sensor of joint(s) {', '.join(extra)} still measures (enableJointForceTorqueSensor)"
    changed = sorted(k for k in now["parameters"] if now["parameters"][k] != baseline["parameters"].get(k))
    if changed:
        return f"physics engine parameter(s) {', '.join(changed)} differ from the scene without it"
    links = sorted(f"{b}/{link}" for (b, link), d in now["dynamics"].items()
                   if baseline["dynamics"].get((b, link)) != d)
    return f"the dynamics of {', '.join(links[:5])} differ from the scene without it" if links else ""


def _module_dir(cls: type) -> Path:
    """Folder of the module defining ``cls`` (relative URDF paths in an example resolve against it)."""
    try:
        return Path(inspect.getfile(cls)).parent
    except (TypeError, OSError):  # defined in a module without a file
        return Path.cwd()


def declaration_problem(ptype: PluginType) -> tuple[str, str] | None:
    """What is wrong with a type's declarations, as ``(check, message)``: its schema is not a schema class (a
    ``robokit.config.Schema``, another pydantic model or a light ``robokit.config.sections.Section``), or its class
    has no docstring. None when both are right."""
    schema, cls = ptype.schema, ptype.cls
    if schema is None or not (isinstance(schema, type) and issubclass(schema, (BaseModel, Section))):
        return ("schema", f"registered config schema {schema!r}; register a robokit.config.Schema (or "
                "robokit.config.sections.Section) subclass (register(name, cls, MyConfig))")
    if not ptype.description:
        return ("description", f"{cls.__name__} has no docstring (its first line is the description "
                "`robokit plugins` shows)")
    return None


def schema_kind(schema: Any) -> str:
    """``"MyConfig (a robokit.config.Schema)"``: a declared schema's name and kind, for a passed check."""
    kind = ("a robokit.config.Schema" if issubclass(schema, Schema) else
            "a robokit.config.sections.Section" if issubclass(schema, Section) else "a pydantic model")
    return f"{schema.__name__} ({kind})"


def first_difference(a: Any, b: Any, path: str = "reading") -> str | None:
    """Where two readings differ (a path like ``reading.ranges[3]``), or None if they are equal.

    Numpy arrays compare exactly (NaN equals NaN); dataclasses field by field; floats exactly (NaN equals NaN).
    """
    if type(a) is not type(b):
        return f"{path} ({type(a).__name__} vs {type(b).__name__})"
    if isinstance(a, np.ndarray):
        if a.shape != b.shape or a.dtype != b.dtype:
            return f"{path} (shape/dtype {a.shape} {a.dtype} vs {b.shape} {b.dtype})"
        equal_nan = a.dtype.kind in "fc"
        return None if np.array_equal(a, b, equal_nan=equal_nan) else f"{path} (arrays differ)"
    if dataclasses.is_dataclass(a):
        pairs: Iterable[tuple[str, Any, Any]] = ((f".{f.name}", getattr(a, f.name), getattr(b, f.name))
                                                 for f in dataclasses.fields(a))
    elif isinstance(a, Mapping):
        if list(a) != list(b):
            return f"{path} (keys {list(a)} vs {list(b)})"
        pairs = ((f"[{k!r}]", a[k], b[k]) for k in a)
    elif isinstance(a, (list, tuple)):
        if len(a) != len(b):
            return f"{path} (length {len(a)} vs {len(b)})"
        pairs = ((f"[{i}]", x, y) for i, (x, y) in enumerate(zip(a, b, strict=True)))
    elif isinstance(a, float) and math.isnan(a):
        return None if math.isnan(b) else f"{path} (nan vs {b!r})"
    else:
        return None if a == b else f"{path} ({a!r} vs {b!r})"
    for suffix, x, y in pairs:
        diff = first_difference(x, y, path + suffix)
        if diff is not None:
            return diff
    return None
