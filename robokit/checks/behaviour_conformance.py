"""Conformance check for behaviour plugin types: :func:`check_behaviour` (use it through :mod:`robokit.testing`).

::

    from robokit.testing import check_behaviour

    def test_my_behaviour_conforms():
        print(check_behaviour("seek"))     # builds it from the class attribute ``example``

The check builds the behaviour from its ``example`` (a minimal scene, its sensors and actuators and the
``[behaviour]`` section, see ``docs/behaviours.md``) in fresh DIRECT-mode simulations and verifies, in order:

1. **declares**: a config schema (a :class:`robokit.config.Schema` subclass, so unknown keys are refused), a
   one-line description (the class docstring); a machine behaviour's ``INITIAL`` and ``TIMEOUTS`` name its states;
2. **pybullet-free**: importing the behaviour's module (in a fresh interpreter) imports neither a physics engine
   (pybullet, mujoco) nor OpenCV — readings in, commands out;
3. **lint**: its module has no wall-clock reads, sleeps or global random generators (:mod:`robokit.checks.lint`);
4. **builds** from the example and **ends with an outcome** (``succeeded``, ``failed`` or ``aborted``) within the
   example's ``world.max_time``;
5. **deterministic, in sim time**: a second fresh simulation with the same seed — run while the wall clock jumps
   an hour at every read and ``time.sleep`` refuses to run — gives the same trace (every record the behaviour
   wrote, transitions included), the same outcome and the same result;
6. **result**: ``result()`` is JSON-serialisable;
7. **readings in, commands out**: during the example run nothing in the world changes while the behaviour's
   ``step()`` runs (no body moved, no joint reset, no velocity set) and ``step()`` calls none of the physics
   engine's mutating functions (forces, motor commands, constraints, dynamics, resets): the behaviour changes the
   world only through the commands it returns.

Every plugin call (the build, each tick's ``step()``, ``result()``) has a wall-clock budget (``budget``, seconds):
a call that never returns fails the check naming the behaviour and the call, instead of hanging the test run
(:mod:`robokit.checks.budget`).

A failed check raises :class:`~robokit.checks.conformance.ConformanceError` naming the type, its distribution and
the check.
"""

from __future__ import annotations

import copy
import enum
import inspect
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robokit.checks.budget import DEFAULT_BUDGET, Beat, Overrun, run_bounded
from robokit.checks.conformance import (
    ConformanceError,
    PassedChecks,
    declaration_problem,
    first_difference,
    schema_kind,
)
from robokit.checks.lint import lint_paths
from robokit.config import build_config
from robokit.core.simulation import Simulation
from robokit.errors import ConfigError, PluginError, UserError
from robokit.plugin_api.plugins import Plugins, PluginType, load_plugins

_UNKNOWN_KEY = "zz_conformance_unknown_key"
_CLOCKS = ("time", "monotonic", "perf_counter", "process_time", "time_ns", "monotonic_ns", "perf_counter_ns")


@dataclass
class BehaviourReport(PassedChecks):
    """What a passed :func:`check_behaviour` verified.

    Attributes:
        type_name: The type checked.
        origin: Its distribution and version.
        outcome: How the example run ended (``status: reason``).
        sim_time: Sim seconds the example run took.
        transitions: State transitions in the example run.
        checks: One line per check passed.
        kind: Always ``"behaviour"`` (the head line of the report's text).
    """

    type_name: str
    origin: str
    outcome: str = ""
    sim_time: float = 0.0
    transitions: int = 0
    checks: list[str] = field(default_factory=list)
    kind: str = "behaviour"


def check_behaviour(
    type_name: str,
    config: Mapping[str, Any] | None = None,
    *,
    scene: Mapping[str, Any] | None = None,
    seed: int = 0,
    extra_plugins: Iterable[object] = (),
    budget: float = DEFAULT_BUDGET,
) -> BehaviourReport:
    """Check that a registered behaviour type keeps the behaviour contract (see the module docstring).

    Args:
        type_name: The behaviour type, as in ``type = "..."``.
        config: The ``[behaviour]`` section without ``type`` (default: ``example["config"]``).
        scene: The other config sections (default: the rest of the type's ``example``).
        seed: The world seed of both simulations.
        extra_plugins: Plugin objects to register besides the installed entry points.
        budget: Wall-clock seconds one plugin call may take (the build, one tick, ``result()``).

    Raises:
        ConformanceError: A check failed.
    """
    return _BehaviourCheck(type_name, config, scene, seed, tuple(extra_plugins), budget).run()


class _BehaviourCheck:
    def __init__(self, type_name: str, config: Mapping[str, Any] | None, scene: Mapping[str, Any] | None, seed: int,
                 extra_plugins: tuple[object, ...], budget: float = DEFAULT_BUDGET) -> None:
        self.type_name, self.seed, self.budget = type_name, seed, budget
        self.plugins: Plugins = load_plugins(extra_plugins)
        try:
            self.ptype: PluginType = self.plugins.get("behaviour", type_name)
        except UserError as exc:
            raise ConformanceError(f"behaviour type {type_name!r}: not registered: {exc}") from None
        self.report = BehaviourReport(type_name, self.ptype.origin)
        self.raw = self._raw(config, scene)
        self.base_dir = _module_dir(self.ptype.cls)

    def fail(self, check: str, message: str) -> ConformanceError:
        return ConformanceError(f"behaviour type {self.type_name!r} ({self.ptype.origin}): {check}: {message}")

    def passed(self, line: str) -> None:
        self.report.checks.append(line)

    def _raw(self, config: Mapping[str, Any] | None, scene: Mapping[str, Any] | None) -> dict[str, Any]:
        declared = getattr(self.ptype.cls, "example", None)
        if declared is None and (config is None or scene is None):
            raise self.fail("example", f"{self.ptype.cls.__name__} declares no `example` (a scene with its sensors "
                            "and actuators and the behaviour's config section, see docs/behaviours.md)")
        example = copy.deepcopy(dict(declared or {}))
        raw = {k: v for k, v in (copy.deepcopy(dict(scene)) if scene is not None else example).items()
               if k != "config"}
        section = copy.deepcopy(dict(config)) if config is not None else dict(example.get("config", {}))
        raw["behaviour"] = {"type": self.type_name, **section}
        return raw

    # ------------------------------------------------------------------ checks
    def run(self) -> BehaviourReport:
        self._check_declarations()
        self._check_unknown_key()
        self._check_imports()
        self._check_lint()
        trace_a, outcome_a, result_a, sim_time = self._run("builds", watch=True)
        if outcome_a is None:
            raise self.fail("outcome", f"no outcome after the example's max_time ({sim_time:g} s sim time): a "
                            "behaviour must end by itself (finish(...)) or declare open_ended = True")
        self.report.outcome, self.report.sim_time = f"{outcome_a.status}: {outcome_a.reason}", sim_time
        self.report.transitions = sum(1 for r in trace_a if r["kind"] == "transition")
        self.passed(f"builds from its example and ends with an outcome ({outcome_a.status} after {sim_time:g} s "
                    f"sim time, {self.report.transitions} transitions)")
        with _jumping_wall_clock() as sleeps:
            trace_b, outcome_b, result_b, _ = self._run("determinism")
        if sleeps:
            raise self.fail("sim time", f"time.sleep was called {len(sleeps)} times during the run")
        self._compare(trace_a, trace_b, outcome_a, outcome_b, result_a, result_b)
        self.passed(f"same seed {self.seed}, same trace, outcome and result, with the wall clock jumping an hour "
                    "per read: decisions are in sim time")
        try:
            json.dumps(result_a)
        except (TypeError, ValueError) as exc:
            raise self.fail("result", f"result() is not JSON-serialisable: {exc}") from None
        self.passed(f"result() is JSON-serialisable ({len(result_a)} keys)")
        self.passed("changes the world only through its commands (nothing moved or driven during step()); every "
                    f"call returned within its {self.budget:g} s budget")
        return self.report

    def _check_declarations(self) -> None:
        schema, cls = self.ptype.schema, self.ptype.cls
        problem = declaration_problem(self.ptype)
        if problem is not None:
            raise self.fail(*problem)
        states = getattr(cls, "STATES", None)
        if isinstance(states, type) and issubclass(states, enum.Enum):
            names = {s.name for s in states}
            unknown = sorted(set(getattr(cls, "TIMEOUTS", {})) - names)
            if unknown:
                raise self.fail("states", f"TIMEOUTS names unknown state(s) {', '.join(unknown)}")
            if not isinstance(getattr(cls, "INITIAL", None), states):
                raise self.fail("states", f"INITIAL is not a member of {states.__name__}")
        self.passed(f"declares schema {schema_kind(schema)}, description {self.ptype.description!r}")

    def _check_unknown_key(self) -> None:
        raw = copy.deepcopy(self.raw)
        raw["behaviour"][_UNKNOWN_KEY] = 1
        try:
            build_config(raw, self.plugins, base_dir=self.base_dir)
        except ConfigError as exc:
            if _UNKNOWN_KEY in str(exc):
                self.passed("rejects unknown config keys")
                return
            raise self.fail("schema", f"the example config does not validate: {exc}") from None
        raise self.fail("schema", f"an unknown key {_UNKNOWN_KEY!r} was accepted; subclass robokit.config.Schema")

    def _check_imports(self) -> None:
        module = self.ptype.cls.__module__
        code = (f"import sys; import {module}; "
                "print(','.join(m for m in ('pybullet', 'mujoco', 'cv2') if m in sys.modules))")
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}  # what this process sees
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False, env=env)
        if proc.returncode != 0:
            raise self.fail("imports", f"importing {module} failed: {proc.stderr.strip().splitlines()[-1:]}")
        heavy = proc.stdout.strip()
        if heavy:
            raise self.fail("imports", f"importing {module} imports {heavy}; a behaviour reads readings and sends "
                            "commands (message types are in robokit.msgs)")
        self.passed(f"importing {module} imports neither pybullet nor OpenCV")

    def _check_lint(self) -> None:
        try:
            path = Path(inspect.getfile(self.ptype.cls))
        except (TypeError, OSError):
            return
        findings = lint_paths([path])
        if findings:
            raise self.fail("lint", f"{len(findings)} finding(s), first: {findings[0]}")
        self.passed(f"{path.name}: no wall clock, sleep or global random generator")

    def _run(self, check: str, watch: bool = False) -> tuple[list[dict[str, Any]], Any, dict[str, Any], float]:
        """Build the example and run it to its outcome (or max_time) in a worker with a budget per call; with
        ``watch``, also fail if the world changes while the behaviour's ``step()`` runs."""
        try:
            return run_bounded(lambda beat: self._simulate(check, beat, watch), self.budget)
        except Overrun as exc:
            raise self.fail("budget", f"{exc} (behaviour {self.type_name!r}): a call must return; wait across "
                            "steps in sim time, never inside one") from None

    def _simulate(self, check: str, beat: Beat, watch: bool) -> tuple[list[dict[str, Any]], Any, dict[str, Any],
                                                                       float]:
        beat("building the example (__init__, setup)")
        try:
            cfg = build_config(self.raw, self.plugins, base_dir=self.base_dir)
            sim = Simulation(cfg, self.plugins, gui=False, seed=self.seed)
        except (UserError, PluginError) as exc:
            raise self.fail(check, f"the example does not build: {exc}") from None
        with sim:
            watcher = _Watcher(sim) if watch else None
            max_ticks = round(cfg.world.max_time / sim.world.time_step)
            try:
                while sim.world.tick < max_ticks and sim.outcome is None:
                    beat(f"step() at tick {sim.world.tick}")
                    sim.step(1)
                    if watcher is not None and watcher.found:
                        raise self.fail("readings in, commands out", watcher.found)
            except PluginError as exc:
                raise self.fail(check, f"raised at tick {sim.world.tick}: {exc}") from None
            finally:
                if watcher is not None:
                    watcher.remove()
            name = cfg.behaviour.name if cfg.behaviour is not None else "behaviour"
            own = [r for r in sim.trace if r["source"] == name]
            beat("result()")
            return own, sim.outcome, dict(sim.behaviour.result()), round(sim.world.time, 6)

    def _compare(self, trace_a: list[dict[str, Any]], trace_b: list[dict[str, Any]], outcome_a: Any, outcome_b: Any,
                 result_a: dict[str, Any], result_b: dict[str, Any]) -> None:
        for i, (a, b) in enumerate(zip(trace_a, trace_b, strict=False)):
            if a != b:
                raise self.fail("determinism", f"trace record {i} differs: {a} vs {b}")
        if len(trace_a) != len(trace_b):
            raise self.fail("determinism", f"trace lengths differ: {len(trace_a)} vs {len(trace_b)} records")
        if outcome_a != outcome_b:
            raise self.fail("determinism", f"outcome differs: {outcome_a} vs {outcome_b}")
        diff = first_difference(result_a, result_b, "result")
        if diff is not None:
            raise self.fail("determinism", f"result differs at {diff}")


@contextmanager
def _jumping_wall_clock() -> Iterator[list[float]]:
    """Make every wall-clock read an hour later than the last, and record (and skip) every ``time.sleep``."""
    saved = {name: getattr(time, name) for name in (*_CLOCKS, "sleep")}
    state = {"now": saved["time"]()}
    sleeps: list[float] = []

    def jump() -> float:
        state["now"] += 3600.0
        return state["now"]

    for name in _CLOCKS:
        setattr(time, name, (lambda: int(jump() * 1e9)) if name.endswith("_ns") else jump)
    time.sleep = sleeps.append  # type: ignore[assignment]
    try:
        yield sleeps
    finally:
        for name, fn in saved.items():
            setattr(time, name, fn)


def _module_dir(cls: type) -> Path:
    try:
        return Path(inspect.getfile(cls)).parent
    except (TypeError, OSError):
        return Path.cwd()


_MUTATORS = ("applyExternalForce", "applyExternalTorque", "setJointMotorControl2", "setJointMotorControlArray",
             "setJointMotorControlMultiDof", "setJointMotorControlMultiDofArray", "resetBasePositionAndOrientation",
             "resetBaseVelocity", "resetJointState", "resetJointStateMultiDof", "changeDynamics", "createConstraint",
             "changeConstraint", "removeConstraint", "removeBody", "loadURDF", "loadSDF", "loadMJCF",
             "createMultiBody", "stepSimulation", "setGravity", "setPhysicsEngineParameter")
"""The physics engine's functions that change the world: a behaviour's ``step()`` calls none of them."""


_WORLD_MUTATORS = ("set_pose", "set_com_pose", "apply_force", "reset_joint", "set_joint_motor", "set_joint_motors",
                   "set_dynamics", "attach", "detach", "couple_joints", "remove_body", "add_primitive", "load_urdf",
                   "load_model", "mount", "step")
"""The World's methods that change the world (every engine has them)."""


class _Watcher:
    """Watches the behaviour's ``step()`` in a real run, on any engine: the world's state (every body's pose and
    velocity, every joint's position and velocity, read through the World) must be the same after it as before
    it, and it must call no mutating method of the World (nor, on PyBullet, of its client). ``found`` says what it
    caught first ("" while nothing)."""

    def __init__(self, sim: Simulation) -> None:
        self.sim, self.found = sim, ""
        self.behaviour = sim.behaviour
        self.inside = False
        world = sim.world
        client = getattr(world, "client", None)
        self._wrapped: list[tuple[Any, str]] = []
        for target, names, engine in ((client, _MUTATORS, True), (world, _WORLD_MUTATORS, False)):
            for name in names:
                original = getattr(target, name, None) if target is not None else None
                if callable(original):
                    setattr(target, name, self._guard(name, original, engine))
                    self._wrapped.append((target, name))
        step = self.behaviour.step

        def watched(readings: Any, t: float) -> Any:
            before = self._state()
            self.inside = True
            try:
                return step(readings, t)
            finally:
                self.inside = False
                self._compare(before, self._state())

        self.behaviour.step = watched

    def _guard(self, name: str, original: Any, engine: bool) -> Any:
        what = f"the physics engine's {name}()" if engine else f"World.{name}()"

        def call(*args: Any, **kwargs: Any) -> Any:
            result = original(*args, **kwargs)  # an engine call inside is named first: it is the more precise
            if self.inside and not self.found:
                self.found = (f"step() at tick {self.sim.world.tick} called {what}: a behaviour changes the world "
                              "only through the commands it returns")
            return result

        return call

    def _state(self) -> dict[str, Any]:
        world = self.sim.world
        names = list(world.body_names)
        ids = [world.body(name) for name in names]
        out = {}
        for name, bid, (pos, orn, lin, ang) in zip(names, ids, world.body_states(ids), strict=True):
            joints = len(world.joints(bid))
            states = world.joint_states(bid, list(range(joints))) if joints else ()
            out[name] = (tuple(pos), tuple(orn), tuple(lin), tuple(ang), tuple((st[0], st[1]) for st in states))
        return out

    def _compare(self, before: dict[str, Any], after: dict[str, Any]) -> None:
        if self.found:
            return
        for name in sorted(set(before) | set(after)):
            if before.get(name) != after.get(name):
                what = "appeared" if name not in before else "disappeared" if name not in after else "moved"
                self.found = (f"body {name!r} {what} during step() at tick {self.sim.world.tick}: a behaviour "
                              "changes the world only through the commands it returns, never through the World")
                return

    def remove(self) -> None:
        for target, name in self._wrapped:
            try:
                delattr(target, name)
            except AttributeError:
                pass
        vars(self.behaviour).pop("step", None)  # the class's own step again
