"""Step a behaviour with scripted readings and no physics: unit tests for behaviours.

A behaviour is readings in, commands out. To test its decisions you do not need a robot: hand it the readings a
situation would produce and look at the commands and states that come out. :class:`ScriptedRun` builds the
behaviour (by type name, validating its config with the type's own schema, or from a class), sets it up with a
context whose components are stand-ins that only declare their ``reading_type``, and steps it at its rate with a
sim clock that advances exactly ``1 / rate_hz`` per step::

    from robokit.msgs import ArmState, GripperState
    from robokit.testing import ScriptedRun

    run = ScriptedRun("pick_place", {"object": "cube", "place_position": [0.4, 0.0, 0.03]},
                      components={"arm": ArmState, "gripper": GripperState, "poses": dict}, bodies=["cube"])
    commands = run.step({"arm": arm_idle, "gripper": gripper_open, "poses": {"cube": cube_pose}})
    assert run.state == "APPROACH" and "arm" in commands

There is no World: ``ctx.world`` is a :class:`ScriptedWorld` with the clock and the named bodies only; a behaviour
that reaches for anything else (physics) gets an ``AttributeError`` saying so — behaviours should not.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robokit.components import Behaviour, Outcome, SetupContext

Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]


class ScriptedWorld:
    """The World as a behaviour may see it in a scripted run: the sim clock and body names (with fixed poses).

    Attributes:
        tick: Physics ticks so far.
        time_step: Seconds per tick.
    """

    def __init__(self, time_step: float, bodies: Mapping[str, Pose | None], seed: int = 0) -> None:
        self.tick = 0
        self.seed = seed
        self.time_step = time_step
        self._bodies = dict(bodies)
        self.gui = False

    @property
    def time(self) -> float:
        """Sim time, seconds."""
        return self.tick * self.time_step

    @property
    def physics_hz(self) -> float:
        """Physics ticks per sim second."""
        return 1.0 / self.time_step

    @property
    def body_names(self) -> list[str]:
        """The scripted bodies' names."""
        return list(self._bodies)

    def has_body(self, name: str) -> bool:
        """True if the script declared a body of that name."""
        return name in self._bodies

    def pose(self, body: str, link: int = -1) -> Pose:
        """The fixed pose the script gave a body (position m, orientation ``(x, y, z, w)``, world frame)."""
        pose = self._bodies.get(body)
        if pose is None:
            raise KeyError(f"scripted world: no pose given for body {body!r} (pass bodies={{name: (pos, orn)}})")
        return pose

    def __getattr__(self, name: str) -> Any:
        raise AttributeError(f"scripted world has no physics: a behaviour stepped with scripted readings used "
                             f"world.{name} (behaviours read readings and send commands)")


class StandIn:
    """A component in a scripted run: it has a name, a kind and the ``reading_type`` a behaviour may check."""

    def __init__(self, name: str, reading_type: type, kind: str) -> None:
        self.name, self.reading_type, self.kind = name, reading_type, kind

    def __repr__(self) -> str:
        return f"<scripted {self.kind} {self.name!r} reading {self.reading_type.__name__}>"


class _Readings(Mapping[str, Any]):
    """The current step's scripted readings; a missing one is a clear KeyError."""

    def __init__(self) -> None:
        self.given: Mapping[str, Any] = {}
        self.t = 0.0

    def __getitem__(self, name: str) -> Any:
        try:
            return self.given[name]
        except KeyError:
            raise KeyError(f"the script gave no reading for {name!r} at t = {self.t:g} s; "
                           f"given: {', '.join(self.given) or '(none)'}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.given)

    def __len__(self) -> int:
        return len(self.given)


class ScriptedRun:
    """One behaviour, stepped by hand with scripted readings (no World, no physics, no plugins but its own).

    Args:
        behaviour: A registered behaviour type name, a Behaviour class, or an instance (not yet set up).
        config: The ``[behaviour]`` section without ``type`` (validated with the type's schema; unknown keys are
            refused as in a config file). Ignored for an instance.
        name: The behaviour's name (trace records' ``source``).
        components: Sensor/actuator name -> reading type (or a ``(reading_type, kind)`` pair; kind defaults to
            ``"sensor"``): what ``ctx.components`` holds.
        bodies: Body names the world knows, or name -> fixed pose.
        rate_hz: Steps per sim second (default: the config's ``rate_hz``, else the physics rate).
        time_step: Physics tick, seconds.
        seed: Seed of ``ctx.rng``.
        schema: The config schema when ``behaviour`` is a class (default: registered type's, or none).
        extra_plugins: Plugin objects to load besides the installed ones (type names are looked up in them).

    Attributes:
        behaviour: The behaviour under test.
        trace: Records written so far (``{"tick", "t", "source", "kind", ...}``, as in a real run).
        commands: Commands returned by each step, in order.
    """

    def __init__(
        self,
        behaviour: str | type[Behaviour] | Behaviour,
        config: Mapping[str, Any] | None = None,
        *,
        name: str = "behaviour",
        components: Mapping[str, type | tuple[type, str]] | None = None,
        bodies: Iterable[str] | Mapping[str, Pose | None] = (),
        rate_hz: float | None = None,
        time_step: float = 1.0 / 240.0,
        seed: int = 0,
        schema: type | None = None,
        extra_plugins: Sequence[object] = (),
        config_dir: str | Path | None = None,
    ) -> None:
        raw = dict(config or {})
        rate = raw.pop("rate_hz", None) if rate_hz is None else rate_hz
        self.behaviour = self._build(behaviour, raw, name, schema, extra_plugins)
        self.world = ScriptedWorld(time_step, bodies if isinstance(bodies, Mapping) else dict.fromkeys(bodies), seed)
        self.period = max(1, round(self.world.physics_hz / rate)) if rate else 1
        self.trace: list[dict[str, Any]] = []
        self.commands: list[Mapping[str, Any]] = []
        self._readings = _Readings()
        stand_ins = {n: StandIn(n, *(spec if isinstance(spec, tuple) else (spec, "sensor")))
                     for n, spec in (components or {}).items()}
        self.ctx = SetupContext(self.world, np.random.default_rng(seed), "behaviour", self._readings,  # type: ignore[arg-type]
                                stand_ins, Path(config_dir) if config_dir else Path.cwd(), self._tracer(name))
        self.behaviour.setup(self.ctx)

    @staticmethod
    def _build(behaviour: str | type[Behaviour] | Behaviour, raw: dict[str, Any], name: str, schema: type | None,
               extra_plugins: Sequence[object]) -> Behaviour:
        if isinstance(behaviour, Behaviour):
            return behaviour
        if isinstance(behaviour, str):
            from robokit.plugin_api.plugins import load_plugins

            ptype = load_plugins(tuple(extra_plugins)).get("behaviour", behaviour)
            cls, schema = ptype.cls, schema or ptype.schema
        else:
            cls = behaviour
        params = schema.model_validate(raw) if schema is not None else (raw or None)  # type: ignore[attr-defined]
        return cls(name, params)  # type: ignore[no-any-return]

    def _tracer(self, source: str) -> Callable[..., None]:
        def trace(kind: str, **data: Any) -> None:
            self.trace.append({"tick": self.world.tick, "t": round(self.world.time, 6), "source": source,
                               "kind": kind, **data})

        return trace

    # ------------------------------------------------------------------ stepping
    @property
    def t(self) -> float:
        """Sim time of the next step, seconds."""
        return self.world.time

    @property
    def outcome(self) -> Outcome | None:
        """The behaviour's outcome (None while it runs)."""
        return self.behaviour.outcome

    @property
    def state(self) -> str | None:
        """The current state's name (machine behaviours), else None."""
        return getattr(self.behaviour, "state_name", None)

    @property
    def states(self) -> list[str]:
        """States entered so far, in order (from the trace's transitions)."""
        return [r["dest_state"] for r in self.trace if r["kind"] == "transition"]

    def step(self, readings: Mapping[str, Any]) -> Mapping[str, Any]:
        """One behaviour step at the current sim time with these readings; the clock then advances one period.

        Returns:
            The commands the behaviour returned (``{}`` for none).
        """
        self._readings.given, self._readings.t = readings, self.world.time
        commands = self.behaviour.step(self._readings, self.world.time) or {}
        self.commands.append(commands)
        self.world.tick += self.period
        return commands

    def run(self, script: Callable[[ScriptedRun, Mapping[str, Any]], Mapping[str, Any]], max_time: float) -> (
            Outcome | None):
        """Step until the behaviour ends or ``max_time`` sim seconds passed.

        Args:
            script: ``script(run, last_commands) -> readings`` for the next step: a tiny model of the world
                (e.g. "the arm reports ``reached`` 0.5 s after a MoveTo").
            max_time: Sim seconds.
        """
        last: Mapping[str, Any] = {}
        while self.outcome is None and self.world.time < max_time - 1e-12:
            last = self.step(script(self, last))
        return self.outcome

    def result(self) -> dict[str, Any]:
        """The behaviour's result, checked to be JSON-serialisable (as a run's result must be)."""
        result = dict(self.behaviour.result())
        json.dumps(result)
        return result
