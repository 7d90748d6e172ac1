"""The small interfaces every plugin type implements, and what each receives.

Lifecycle, in order, for sensors, actuators and behaviours:

1. ``__init__(name, config)`` — when the simulation is built; ``config`` is the validated, frozen pydantic model
   of the type's section (or ``None`` if the type registered no schema). Do not touch the world here.
2. ``setup(ctx)`` — once, after every body is in the world and before the first tick. Look up bodies, joints and
   links by name here and raise :class:`robokit.errors.ConfigError` (with a ``key``) for bad names.
3. per tick, at the component's rate (see :mod:`robokit.core.scheduler`):
   sensors ``read()``, behaviours ``step(readings, t)``, actuators ``update()``.
4. ``close()`` — once, when the simulation closes; release anything held.

Two optional hooks let any type, built-in or third-party, state what it knows about its task:

- ``preflight(ctx)`` — after every component's ``setup`` and before the first tick (``robokit validate`` runs
  it too): return a list of problems (:class:`~robokit.errors.ConfigError`, each naming a key) found without
  running, e.g. a target out of the arm's reach. ``validate`` refuses a config with problems (exit 2); ``run``
  prints them as warnings and runs, and the goal check then says what happened.
- ``check_goal(world)`` (behaviours) — once, after the last tick: the task's goal evaluated on the world's
  ground truth, not on the behaviour's belief. A :class:`GoalCheck` that is not met turns a ``succeeded``
  outcome into ``failed`` with the check's reason.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from robokit.errors import ConfigError, LookupNameError

if TYPE_CHECKING:
    from robokit.core.world import JointInfo, World

OUTCOMES = ("succeeded", "failed", "aborted")


@dataclass(frozen=True)
class Outcome:
    """How a behaviour ended: ``status`` is one of ``succeeded``, ``failed``, ``aborted``; ``reason`` says why."""

    status: str
    reason: str = ""

    def __post_init__(self) -> None:
        if self.status not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, got {self.status!r}")


@dataclass(frozen=True)
class GoalCheck:
    """A behaviour's goal evaluated on the world at the end of a run (ground truth).

    Attributes:
        met: The goal holds in the world.
        reason: One line: what was checked, or which objects miss the goal and why.
        details: JSON-ready facts for the result (``result["goal"]``), e.g. per-object findings.
    """

    met: bool
    reason: str = ""
    details: Mapping[str, Any] = field(default_factory=dict)


@dataclass(eq=False, repr=False)
class SetupContext:
    """What a component receives in ``setup``: one per component, compared by identity (``dataclasses.replace``
    makes a changed copy, as composites do for their children).

    Attributes:
        world: The World, the one interface to physics (bodies by name, joints, contacts, rays, the clock; see
            robokit.engines.interface). Behaviours should not drive physics through it: readings in, commands out.
        rng: This component's own generator, spawned from the run's seed (independent of other components). For
            noise drawn at each reading use :meth:`tick_rng` (an extra read must not change later readings).
        key: The component's config key path, e.g. ``"sensors.cam"``; prefix errors with it.
        readings: Live view of every sensor's and actuator's latest reading, by component name.
        components: Every sensor and actuator instance by name (to check what another one is).
        config_dir: Folder of the config file (resolve relative paths against it).
        trace: ``trace(kind, **data)`` appends a record to the run's trace at the current tick.
        body_keys: Config key of every spawned body by name (``red_0`` -> ``bodies.red``), to name keys in
            problems.
        run_dir: The run's record folder (``results/<run_id>``) when the run keeps one, else None.
        save_frames: True when the user asked every camera to save the frames it renders (``--save-frames``).
    """

    world: World
    rng: np.random.Generator
    key: str
    readings: Mapping[str, Any]
    components: Mapping[str, Any]
    config_dir: Any
    trace: Callable[..., None]
    body_keys: Mapping[str, str] = field(default_factory=dict)
    run_dir: Path | None = None
    save_frames: bool = False

    def tick_rng(self, tick: int | None = None) -> np.random.Generator:
        """A generator for noise drawn at one tick (default: now), the same however often the component reads.

        Seeded from the run's seed, this component's config key and the tick, so a reading's noise depends on
        *when* it is measured, never on how many reads came before: a test or a monitor that looks at a sensor
        cannot change the run. Use it for sensor noise; use :attr:`rng` for draws made once (in ``setup``).
        """
        k = self.world.tick if tick is None else tick
        words = (int(self.world.seed), zlib.crc32(self.key.encode("utf-8")), int(k))
        if all(0 <= w < 2**32 for w in words):  # the same seed words numpy makes of the list, in fewer steps
            seq = np.random.SeedSequence(np.array(words, dtype=np.uint32))
            return np.random.Generator(np.random.PCG64(seq))
        return np.random.default_rng(list(words))

    def problem(self, message: str, key: str = "") -> ConfigError:
        """A problem placed under this component's section (``key`` relative to it), for ``preflight``."""
        return ConfigError(message, key=".".join(part for part in (self.key, key) if part))

    def body_key(self, name: str) -> str:
        """The config key that created body ``name`` (``bodies.red`` for ``red_0``), or ``bodies.<name>``."""
        return self.body_keys.get(name, f"bodies.{name}")

    def body(self, name: str, *, key: str = "body") -> int:
        """Body id of a named body; a config error at ``key`` (listing the bodies) if there is none."""
        return _as_config_error(key, self.world.body, name)  # type: ignore[no-any-return]

    def link(self, body: str, link: str, *, key: str = "link") -> int:
        """Link index by name (``-1`` = base); a config error at ``key`` (listing the links) if there is none."""
        self.body(body)
        return _as_config_error(key, self.world.link, body, link)  # type: ignore[no-any-return]

    def joint(self, body: str, joint: str, *, key: str = "joint") -> JointInfo:
        """A joint by name; a config error at ``key`` (listing the joints) if there is none."""
        self.body(body)
        return _as_config_error(key, self.world.joint, body, joint)  # type: ignore[no-any-return]


def _as_config_error(key: str, lookup: Callable[..., Any], *args: Any) -> Any:
    """Call a World lookup; an unknown name becomes a ConfigError placed at ``key``."""
    try:
        return lookup(*args)
    except LookupNameError as exc:
        raise ConfigError(str(exc), key=key) from None


class Sensor:
    """Base class of sensors. Subclasses implement :meth:`read`.

    A sensor's reading is *lazy* by default: when the sensor is due (every ``1/rate_hz`` sim seconds) it is only
    marked stale, and :meth:`read` runs the first time something looks at the reading. Set ``lazy = False`` for
    sensors that must observe every due tick (for example ones that integrate).
    """

    kind: ClassVar[str] = "sensor"
    lazy: ClassVar[bool] = True
    allow_inf: ClassVar[bool] = False
    """True if ``+inf``/``-inf`` are valid values in readings (a lidar's "no return"); NaN is always flagged."""
    reading_type: ClassVar[type] = object
    """The type every reading is an instance of (checked by :func:`robokit.testing.check_sensor`)."""
    example: ClassVar[dict[str, Any] | None] = None
    """A minimal scene and config section to build this type from (used by the conformance checks in
    :mod:`robokit.testing`): ``{"config": {...section without type...}, "bodies": {...}, ...}``."""

    def __init__(self, name: str, config: Any) -> None:
        self.name = name
        self.config = config

    def setup(self, ctx: SetupContext) -> None:
        """Resolve names and allocate what the sensor needs. Runs once before the first tick."""
        self.ctx = ctx
        self.world = ctx.world

    def read(self) -> Any:
        """Measure now and return a reading (an instance of ``reading_type``)."""
        raise NotImplementedError

    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Problems found without running (after every component's setup); each names a key. Default: none."""
        return []

    def close(self) -> None:
        """Release what the sensor holds. Runs once when the simulation closes."""


class Actuator:
    """Base class of actuators.

    :meth:`command` receives what the behaviour sent (as soon as the behaviour returns it); :meth:`update` runs at
    the actuator's rate and pushes motor commands into the world; :meth:`read` reports the actuator's state.
    """

    kind: ClassVar[str] = "actuator"
    reading_type: ClassVar[type] = object
    example: ClassVar[dict[str, Any] | None] = None
    """Like :attr:`Sensor.example`, plus optional ``"commands"``: ``(tick, command)`` pairs sent to the actuator."""

    def __init__(self, name: str, config: Any) -> None:
        self.name = name
        self.config = config

    def setup(self, ctx: SetupContext) -> None:
        """Resolve joints by name and put the device into its start state. Runs once before the first tick."""
        self.ctx = ctx
        self.world = ctx.world

    def command(self, cmd: Any) -> None:
        """Accept a command from the behaviour. Raise ``ValueError`` with a clear message for a bad one."""
        raise NotImplementedError

    def update(self) -> None:
        """Apply the current command to the world. Runs at the actuator's rate, after the behaviour."""

    def read(self) -> Any:
        """Return the actuator's state as a reading."""
        return None

    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Problems found without running (after every component's setup); each names a key. Default: none."""
        return []

    def close(self) -> None:
        """Release what the actuator holds (constraints, debug items). Runs once when the simulation closes."""


class Behaviour:
    """Base class of behaviours: readings in, commands out. Never import pybullet in a behaviour.

    :meth:`step` runs at the behaviour's rate with a read-only mapping of readings by component name and the sim
    time in seconds; it returns a mapping of actuator name to command (or ``None`` for no new commands). When the
    behaviour is done it sets :attr:`outcome`; the loop stops after that tick.
    """

    kind: ClassVar[str] = "behaviour"
    open_ended: ClassVar[bool] = False
    """True for behaviours with no natural end (teleop): reaching ``max_time`` then counts as success."""
    started_at: float | None = None

    def __init__(self, name: str, config: Any) -> None:
        self.name = name
        self.config = config
        self.outcome: Outcome | None = None
        self.started_at = None
        """Sim time (the world's clock) this behaviour started: set by the composite that starts it (a sequence
        step, a retry), else at its first call of :meth:`elapsed`."""

    def elapsed(self, t: float) -> float:
        """Sim seconds since this behaviour started: its own stopwatch. ``t`` (what :meth:`step` receives) is
        always the world's sim time, the same for every behaviour, step, sub-machine and monitor; use this for
        durations counted from the behaviour's start (a ``duration``, a ``timeout``)."""
        if self.started_at is None:
            self.started_at = t
        return t - self.started_at

    def setup(self, ctx: SetupContext) -> None:
        """Check the components it needs exist (raise ``ConfigError`` otherwise). Runs once before the first tick."""
        self.ctx = ctx

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Advance one step; return commands by actuator name."""
        raise NotImplementedError

    def finish(self, status: str, reason: str = "") -> None:
        """Set the outcome (``succeeded``, ``failed`` or ``aborted``) once; later calls are ignored."""
        if self.outcome is None:
            self.outcome = Outcome(status, reason)

    def result(self) -> dict[str, Any]:
        """The behaviour's own result, JSON-serialisable. Called at the end, also after an error or interrupt."""
        return {}

    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Problems found without running (after every component's setup); each names a key. Default: none."""
        return []

    def check_goal(self, world: World) -> GoalCheck | None:
        """The task's goal, evaluated once after the last tick on the world's ground truth (body poses, not
        readings or the behaviour's belief). None (the default) states no goal: the outcome is the behaviour's.

        A check that is not met turns ``succeeded`` into ``failed`` with its reason; name the objects that miss
        the goal and why (never seen, unreachable, dropped...).
        """
        return None

    def close(self) -> None:
        """Release what the behaviour holds."""


@dataclass(frozen=True)
class Delivery:
    """What a reporter did with a result.

    Attributes:
        delivered: The result reached its destination.
        stored: A local path where the result is kept (a result file or an outbox entry), if any.
        message: One line for the run summary.
    """

    delivered: bool
    stored: str | None = None
    message: str = ""


class Reporter:
    """Base class of reporters: deliver a finished run's payload somewhere. Runs after the simulation ended."""

    kind: ClassVar[str] = "reporter"
    sends: ClassVar[bool] = False
    """True for reporters that send over a network (they run after the local ones)."""

    def __init__(self, name: str, config: Any) -> None:
        self.name = name
        self.config = config

    def report(self, payload: dict[str, Any]) -> Delivery:
        """Deliver the payload (the RunResult dict plus course fields). Must not raise for delivery failures."""
        raise NotImplementedError

    @property
    def uploads_record(self) -> bool:
        """True when the reporter also uploads the run folder's files (its config's ``upload_artifacts``): the
        run's pose log is then written before it runs, so the upload includes the 3D replay."""
        return bool(getattr(self.config, "upload_artifacts", False))

    def keep(self, payload: dict[str, Any]) -> Delivery:
        """Keep the payload without sending it: called instead of :meth:`report` once the user pressed Ctrl-C (or
        sent SIGTERM), who wants the process to end now. The default calls :meth:`report` (right for reporters that
        write local files); reporters that send over a network queue the payload for a later delivery."""
        return self.report(payload)
