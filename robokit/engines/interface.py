"""The World interface: the one door to physics for plugins and behaviours, whatever the engine.

:class:`World` holds what every engine shares (the name registry, the sim clock, the run's random generator, name
lookups, seeded placement) and declares, as abstract methods, everything an engine must answer. An engine is a
subclass (``robokit/engines/pybullet/``: :class:`~robokit.engines.pybullet.PyBulletWorld`); ``World(...)``
itself builds the engine named by ``engine=`` (default ``"pybullet"``), so code written against today's World
keeps working.

Conventions every engine keeps:

- Units are SI: metres, kilograms, seconds, newtons, radians (degrees only where a name says ``_deg``).
- Positions are world frame ``(x, y, z)``; quaternions are ``(x, y, z, w)``; rotation matrices are 9 floats, row
  by row.
- Bodies are ints (ids handed out by the engine, registered under names); links are ints, ``-1`` = the base,
  else the index of the joint whose child the link is; joints are ints (their index), looked up by name once at
  set-up (:meth:`World.joint`, :meth:`World.link`).
- "Link frame" is the frame the model file (URDF/SDF/MJCF) gives a link; "centre-of-mass frame" is the link's
  inertial frame (where forces act). :meth:`World.pose` gives link frames.
- Joint values are radians (revolute) or metres (prismatic); joint rates rad/s or m/s; efforts N·m or N.

This module imports no engine: it is what ``plugins/`` and ``behaviours/`` may rely on.
"""

from __future__ import annotations

import math
import os
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Literal, NamedTuple, Protocol

import numpy as np

from robokit.errors import LookupNameError, UserError

if TYPE_CHECKING:  # read by attribute only
    from robokit.config import Config

DATA_DIR = Path(__file__).resolve().parents[1] / "data"
"""URDFs and meshes bundled with robokit (searched after the config's folder and ``pybullet_data``)."""

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Pose = tuple[Vec3, Quat]
MotorMode = Literal["position", "velocity", "torque"]
"""Joint motor modes: hold a target position (PD), a target velocity, or apply a torque (force) for one step."""

KEY_DOWN = 1
""":meth:`World.key_events` flag: the key is held down now."""
KEY_TRIGGERED = 2
""":meth:`World.key_events` flag: the key went down since the last call (also a tap already released)."""
KEY_RELEASED = 4
""":meth:`World.key_events` flag: the key went up since the last call."""
KEY_UP, KEY_DOWN_ARROW, KEY_LEFT, KEY_RIGHT, KEY_RETURN = 65297, 65298, 65295, 65296, 65309
""":meth:`World.key_events` codes of the arrow keys and Return (printable keys are ``ord(character)``, lower
case). The values are PyBullet's GUI codes; another engine's viewer maps its own codes onto these."""


@dataclass(frozen=True)
class JointInfo:
    """One joint of a multibody, as read from the model file (lesson 02's joint table).

    Limits are radians for revolute joints and metres for prismatic ones; ``max_force`` in N or N·m,
    ``max_velocity`` in rad/s or m/s. ``child_link`` is the link the joint moves.
    """

    index: int
    name: str
    type: str
    lower: float
    upper: float
    max_force: float
    max_velocity: float
    damping: float
    friction: float
    child_link: str

    @property
    def movable(self) -> bool:
        """True for revolute and prismatic joints (the ones IK and joint control drive)."""
        return self.type in ("revolute", "prismatic")


class Contact(NamedTuple):
    """One contact point of a :meth:`World.contacts` query, seen from body A (the queried body).

    Attributes:
        other: Body id of the other body (B).
        link: Link of body A in contact (``-1`` = base).
        other_link: Link of body B in contact.
        normal_force: Normal force of the contact in the last physics step, N (>= 0).
        position: Contact point on body B, metres, world frame.
        normal: Contact normal, pointing from B to A, world frame (unit vector).
    """

    other: int
    link: int
    other_link: int
    normal_force: float
    position: Vec3
    normal: Vec3


class JointState(NamedTuple):
    """State of one joint after the last physics step (:meth:`World.joint_states`).

    Read it by index (``[0]`` position, ``[1]`` velocity, ``[2]`` reaction, ``[3]`` torque): an engine may hand back
    plain tuples of this layout (PyBullet does: controllers read joint states every tick).

    Attributes:
        position: rad (revolute) or m (prismatic).
        velocity: rad/s or m/s.
        reaction: The joint's reaction wrench ``(Fx, Fy, Fz, Mx, My, Mz)`` (N, N·m) in the child link's joint frame;
            zeros unless :meth:`World.enable_joint_wrench` switched it on.
        torque: The effort the motor applied in the last step, N·m or N (PyBullet: 0 in torque mode).
    """

    position: float
    velocity: float
    reaction: tuple[float, float, float, float, float, float]
    torque: float


class ChainFrame(NamedTuple):
    """A fixed transform along a :meth:`World.kinematic_chain`: position (m) and orientation ``(x, y, z, w)`` of the
    next frame in the current one."""

    position: Vec3
    orientation: Quat


class ChainJoint(NamedTuple):
    """A joint along a :meth:`World.kinematic_chain`: the current frame moves by the joint's value about (revolute)
    or along (prismatic) ``axis`` (a unit-free vector in the current frame); other joint types do not move it."""

    joint: int
    axis: Vec3
    type: str


class Clash(NamedTuple):
    """Two bodies closer than a margin in a :meth:`World.clashes` query (a configuration tried, not stepped).

    Attributes:
        body: The arm's body id, or a carried body's.
        link: Its link (``-1`` = base).
        other: The other body's id.
        other_link: The other body's link.
        distance: Signed distance between the two, metres (negative: they interpenetrate by that much).
    """

    body: int
    link: int
    other: int
    other_link: int
    distance: float


class RayHits(NamedTuple):
    """Answers of a batch of rays, as arrays (one entry per ray).

    Attributes:
        body: Hit body id per ray, ``-1`` for no hit.
        link: Hit link index (``-1`` = base, or no hit).
        fraction: Hit fraction along the segment from start to end, ``1.0`` for no hit.
        position: Hit point, world frame (``(0, 0, 0)`` for no hit); None unless asked for.
        normal: Hit normal, world frame (``(0, 0, 0)`` for no hit); None unless asked for.
        cast: Per ray, True if the engine's own ray test answered it (False: answered another way, e.g.
            PyBullet's static boxes intersected in numpy).
    """

    body: np.ndarray
    link: np.ndarray
    fraction: np.ndarray
    position: np.ndarray | None
    normal: np.ndarray | None
    cast: np.ndarray


class RayCaster(Protocol):
    """Casts batches of ray segments in one world (:meth:`World.ray_caster`). Segments are world frame, metres.

    The rule every engine follows: a segment reports the first surface it *enters* between its start and its end.

    - A ray that starts inside a shape (or on its surface, pointing out) passes through that shape: the face it
      leaves by is not a hit, and a surface beyond it (or inside it: another body's) is.
    - A ray that starts on a surface and points into the shape hits it at fraction 0.
    - The end is not part of the segment: a surface exactly at the end is not a hit (at most the range).
    - A zero-length segment hits nothing (body -1, fraction 1.0).
    - A ray along a face's plane, touching the shape only at its boundary, may or may not report it (engines
      differ at exactly 0); a ray 1 µm outside a face misses it, 1 mm inside hits the face it enters.

    ``tests/test_engine_contract.py`` checks each case on every engine.
    """

    rays_cast: int
    """Rays the engine's own ray test cast so far (for benchmarks and tests)."""
    rays_total: int
    """Rays answered so far."""

    def cast(self, starts: np.ndarray, ends: np.ndarray, *, detail: bool = True) -> RayHits:
        """Answers for the segments ``starts[i] -> ends[i]`` (arrays ``(N, 3)``). ``detail=False`` leaves out hit
        positions and normals (``None``)."""

    def starts(self, n: int) -> np.ndarray:
        """The caster's own (3, n) buffer of segment starts that :meth:`cast_lean` reads, to fill in place."""

    def cast_lean(self, ends: np.ndarray, inv_len: np.ndarray, *, ignore: int = -2,
                  refresh: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Hit body (``-1``: none) and fraction per segment, from :meth:`starts` to ``ends`` (3, N), given
        ``1 / length`` of each segment; a hit on body ``ignore`` counts as none. ``refresh=False``: the caller
        called :meth:`refresh` just before (nothing moved since)."""

    def refresh(self) -> None:
        """Re-read the scene (bodies added or removed, poses) before a :meth:`cast_lean` with ``refresh=False``."""


class RenderedImage(NamedTuple):
    """One camera image (:meth:`World.render`).

    Attributes:
        rgb: ``(height, width, 3)`` uint8.
        depth: ``(height, width)`` float32, distance along the view axis in metres (``near`` .. ``far``).
        segmentation: ``(height, width)`` int32 body id per pixel (``-1``: background), or None if not asked for.
    """

    rgb: np.ndarray
    depth: np.ndarray
    segmentation: np.ndarray | None


def display_problem() -> str | None:
    """Why no GUI window can open on this machine now, or None if one can. On Linux a window needs an X display:
    ``$DISPLAY`` set and opening (asked of libX11, the library the engines' windows use); elsewhere None (the
    platform's own window system)."""
    if not sys.platform.startswith("linux"):
        return None
    display = os.environ.get("DISPLAY")
    if not display:
        return "no display (DISPLAY is not set); run headless, or under xvfb-run for a virtual one"
    import ctypes
    import ctypes.util  # here, not at import: ctypes.util imports subprocess and tempfile, a cost every run paid

    try:
        x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    except OSError:
        return None  # no libX11 to ask: let the engine try
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    handle = x11.XOpenDisplay(display.encode())
    if not handle:
        return f"display {display!r} does not open (is its X server running?)"
    x11.XCloseDisplay(handle)
    return None


def yaw_of(quaternion: Sequence[float]) -> float:
    """Yaw (rotation about +z, radians, in (-pi, pi]) of a quaternion ``(x, y, z, w)``."""
    x, y, z, w = quaternion
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class World(ABC):
    """The physics of one run: named bodies, the sim clock, the run's random generator, and the engine's answers.

    ``World(engine="pybullet", ...)`` builds the named engine's World (the class registered in
    :attr:`engines`); every engine takes the keyword arguments below. Two Worlds in one process are fully
    independent. A World owns its engine: nothing else keeps engine handles or steps the physics.

    Args:
        gui: Open the engine's interactive viewer instead of running headless.
        time_step: Physics step in seconds (default 1/240 s).
        gravity: Gravity vector in m/s², world frame.
        solver_iterations: Constraint solver iterations per step.
        seed: Seed of the run's :class:`numpy.random.Generator`, the only source of randomness.
        base_dir: Folder that relative model paths are resolved against (the config file's folder).
        engine: Which engine ``World(...)`` builds (a key of :attr:`engines`).
    """

    engines: ClassVar[dict[str, Callable[[], type[World]]]] = {}
    """Engine name -> a function returning its World class (imported only when asked for)."""
    engine: ClassVar[str] = ""
    """This World's engine name."""
    engine_version: ClassVar[str] = ""
    """The engine package's version (``"3.2.7"``, ``"4.0.0"``), as a run's result names it."""
    client: Any
    """The engine's own handle (PyBullet: the ``BulletClient``; None once closed). Engine-specific: plugins and
    behaviours never touch it (a test enforces it); robokit's engine-aware tools may."""

    def __new__(cls, *args: Any, **kwargs: Any) -> World:  # noqa: ARG004 - __init__ takes them
        if cls is World:
            cls = World.engine_class(str(kwargs.get("engine") or "pybullet"))
        return super().__new__(cls)

    @staticmethod
    def create(engine: str = "pybullet", **kwargs: Any) -> World:
        """A World of the named engine: ``World.create("pybullet", seed=3)`` (the keyword arguments of
        :class:`World`). The same as ``World(engine=..., ...)``, in a form type checkers accept."""
        return World.engine_class(engine)(**kwargs)

    @staticmethod
    def engine_class(name: str) -> type[World]:
        """The World class of an engine by name.

        Raises:
            UserError: No engine of that name (the message lists the known ones).
        """
        try:
            loader = World.engines[name]
        except KeyError:
            raise LookupNameError("engine", name, sorted(World.engines)) from None
        return loader()

    @classmethod
    def check_config(cls, config: Config, *, gui: bool | None = None) -> None:
        """Refuse, before anything is built, the first thing in ``config`` this engine cannot honour.

        ``gui`` is the run's override of ``world.gui`` (None: the config's). This default accepts everything; an
        engine that cannot honour a setting overrides it (``World.engine_class(name).check_config(config)``).

        Raises:
            ConfigError: One line naming the file, the key and the engine.
        """
        return None  # this engine honours every setting

    @classmethod
    def window_problem(cls) -> str | None:
        """Why this engine cannot open its GUI window on this machine now, or None if it can. ``World(gui=True)``
        raises it as a one-line error rather than opening; a Gymnasium env lists the ``"human"`` render mode only
        when it is None. This default: the engine has no window."""
        return f"the {cls.engine} engine has no GUI window"

    def __init__(
        self,
        *,
        gui: bool = False,
        time_step: float = 1.0 / 240.0,
        gravity: Sequence[float] = (0.0, 0.0, -9.81),
        solver_iterations: int = 50,
        seed: int = 0,
        base_dir: str | Path = ".",
        engine: str | None = None,
    ) -> None:
        if engine is not None and engine != self.engine:
            raise UserError(f"{type(self).__name__} is the {self.engine!r} engine, not {engine!r}")
        self.gui = gui
        self.time_step = float(time_step)
        self.seed = int(seed)
        self.base_dir = Path(base_dir)
        self._rng: np.random.Generator | None = None
        self.tick = 0
        self._bodies: dict[str, int] = {}
        self._names: dict[int, str] = {}
        self.mounts: dict[int, int] = {}
        """Mounted body id -> the body id it is mounted on (see :meth:`mount`)."""
        self.removals = 0
        """Bodies removed so far: lets components cache id lookups until it changes."""
        self.render_options: dict[str, Any] = {}
        """Extra renderer options every camera passes (``lightDirection``: set by ``[randomize]``)."""

    # ----------------------------------------------------------------- randomness, clock
    @property
    def rng(self) -> np.random.Generator:
        """The run's :class:`numpy.random.Generator`, seeded with :attr:`seed`: the only source of randomness.

        Made on first use, which gives the same numbers as making it with the World (nothing draws before): a run
        that draws nothing never imports ``numpy.random`` (a tenth of a trivial run's start-up).
        """
        if self._rng is None:
            self._rng = np.random.default_rng(self.seed)
        return self._rng

    @rng.setter
    def rng(self, generator: np.random.Generator) -> None:
        self._rng = generator

    @property
    def time(self) -> float:
        """Simulated seconds since the start of the run (``tick * time_step``)."""
        return self.tick * self.time_step

    @property
    def physics_hz(self) -> float:
        """Physics steps per simulated second."""
        return 1.0 / self.time_step

    @abstractmethod
    def step(self) -> None:
        """Advance physics by one step (:attr:`time_step`) and :attr:`tick` by one. Only the scheduler calls this."""

    # ----------------------------------------------------------------- the registry (engine-neutral)
    def _register(self, name: str, body_id: int) -> int:
        if name in self._bodies:
            raise UserError(f"a body named {name!r} already exists")
        self._bodies[name] = body_id
        self._names[body_id] = name
        return body_id

    def _unregister(self, name: str) -> int:
        body = self._bodies.pop(name)
        del self._names[body]
        self.removals += 1
        return body

    @property
    def body_names(self) -> list[str]:
        """Names of every registered body, in creation order."""
        return list(self._bodies)

    def body(self, name: str | int) -> int:
        """Body id of a registered name (an int is passed through after a check).

        Raises:
            LookupNameError: No body has that name; the message lists the valid names.
        """
        if isinstance(name, int):
            if name not in self._names:
                raise LookupNameError("body id", str(name), [str(i) for i in self._names])
            return name
        try:
            return self._bodies[name]
        except KeyError:
            raise LookupNameError("body", name, self._bodies) from None

    def has_body(self, name: str) -> bool:
        """True if a body with this name is registered."""
        return name in self._bodies

    def body_name(self, body_id: int) -> str | None:
        """Registered name of a body id, or None for bodies created outside the registry."""
        return self._names.get(body_id)

    def attached(self, body: str | int) -> set[int]:
        """Ids of the bodies joined to ``body`` by mounts, directly or through others (``body`` included)."""
        group = {self.body(body)}
        grew = True
        while grew:
            grew = False
            for child, parent in self.mounts.items():
                if (child in group) != (parent in group):
                    group |= {child, parent}
                    grew = True
        return group

    def joint(self, body: str | int, joint_name: str) -> JointInfo:
        """Look a joint up by name.

        Raises:
            LookupNameError: The body has no such joint; the message lists its joints.
        """
        infos = self.joints(body)
        for info in infos:
            if info.name == joint_name:
                return info
        raise LookupNameError("joint", joint_name, [j.name for j in infos], where=self._label(body))

    def link(self, body: str | int, link_name: str) -> int:
        """Link index by name: ``-1`` for the base link, else the index of the joint whose child it is.

        ``"base"`` names the base link of any body. A primitive body (``shape = ...``) has only that link, which
        pybullet calls ``link0``; both names work.

        Raises:
            LookupNameError: The body has no such link; the message lists its links.
        """
        if link_name == "base" or link_name == self.base_link_name(body):
            return -1
        infos = self.joints(body)
        for info in infos:
            if info.child_link == link_name:
                return info.index
        valid = ["base", self.base_link_name(body)] + [j.child_link for j in infos]
        raise LookupNameError("link", link_name, valid, where=self._label(body))

    def link_names(self, body: str | int) -> list[str]:
        """Every link name of a body, base first."""
        return [self.base_link_name(body)] + [j.child_link for j in self.joints(body)]

    def _label(self, body: str | int) -> str:
        return body if isinstance(body, str) else (self.body_name(body) or f"body {body}")

    def resolve_urdf(self, urdf: str) -> str:
        """Find a model file (URDF, SDF or MJCF): a path relative to the config folder, robokit's bundled data,
        or a ``pybullet_data`` name.

        Raises:
            UserError: The file exists in none of those places (the message lists where it looked).
        """
        import pybullet_data  # model files only (the package holds no engine code)

        candidates = [self.base_dir / urdf, DATA_DIR / urdf, Path(pybullet_data.getDataPath()) / urdf]
        if Path(urdf).is_absolute():
            candidates = [Path(urdf)]
        for cand in candidates:
            if cand.is_file():
                return str(cand.resolve())
        looked = ", ".join(str(c.parent) for c in candidates)
        kind = {".sdf": "SDF", ".xml": "MJCF", ".mjcf": "MJCF"}.get(Path(urdf).suffix.lower(), "URDF")
        raise UserError(f"{kind} {urdf!r} not found (looked in {looked})")

    def sample_positions(
        self,
        count: int,
        low: Sequence[float],
        high: Sequence[float],
        *,
        min_spacing: float = 0.0,
        avoid: Iterable[tuple[Sequence[float], Sequence[float]]] = (),
        clearance: float = 0.0,
        existing: Iterable[Sequence[float]] = (),
        max_tries: int = 10_000,
    ) -> np.ndarray:
        """Draw ``count`` (x, y) points uniformly in a rectangle, pairwise at least ``min_spacing`` apart.

        Points also keep ``min_spacing`` from ``existing`` points and ``clearance`` from the xy footprint of
        every box in ``avoid`` (``(min, max)`` corners). Draws only from the run's generator.

        Raises:
            UserError: The points do not fit after ``max_tries`` draws.
        """
        lo, hi = np.asarray(low, float)[:2], np.asarray(high, float)[:2]
        boxes = [(np.asarray(a, float)[:2] - clearance, np.asarray(b, float)[:2] + clearance) for a, b in avoid]
        placed: list[np.ndarray] = [np.asarray(e, float)[:2] for e in existing]
        out: list[np.ndarray] = []
        for _ in range(max_tries):
            if len(out) == count:
                break
            cand = self.rng.uniform(lo, hi)
            if any(np.linalg.norm(cand - q) < min_spacing for q in placed):
                continue
            if any(bool(np.all(cand >= a) and np.all(cand <= b)) for a, b in boxes):
                continue
            placed.append(cand)
            out.append(cand)
        if len(out) < count:
            raise UserError(
                f"could not place {count} objects {min_spacing} m apart in x {lo[0]}..{hi[0]}, y {lo[1]}..{hi[1]}"
            )
        return np.array(out).reshape(count, 2)

    # ----------------------------------------------------------------- building the scene
    @abstractmethod
    def add_primitive(
        self,
        name: str,
        shape: str,
        *,
        size: Sequence[float] = (0.1, 0.1, 0.1),
        radius: float = 0.05,
        height: float = 0.1,
        mass: float = 1.0,
        position: Sequence[float] = (0.0, 0.0, 0.0),
        orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0),
        lateral_friction: float | None = None,
        rolling_friction: float | None = None,
        spinning_friction: float | None = None,
        restitution: float | None = None,
        linear_damping: float | None = None,
        angular_damping: float | None = None,
        mesh_collision: bool = False,
    ) -> int:
        """Create a box (``size`` = full edge lengths, m), sphere (``radius``) or cylinder (``radius``, ``height``
        along its z axis) with its base frame at ``position`` / ``orientation``; register it as ``name``.

        A ``mass`` (kg) of 0 makes the body static. ``rgba`` colour in 0..1. ``mesh_collision``: a static box whose
        collision shape is a triangle mesh (an engine without the distinction builds a box). Returns the body id.

        Raises:
            UserError: Unknown shape, a name already taken, or ``mesh_collision`` on a body with mass.
        """

    @abstractmethod
    def set_dynamics(self, body: int | str, link: int = -1, **params: float | None) -> None:
        """Set contact and damping parameters of one link (``-1`` = base); ``None`` values are left alone.

        Keywords: ``lateral_friction``, ``rolling_friction``, ``spinning_friction`` (coefficients),
        ``restitution`` (0..1), ``linear_damping``, ``angular_damping``, ``mass`` (kg), ``friction_anchor`` (True:
        keep static friction anchored at the contact, for fingers that hold; engines without it ignore it),
        ``joint_damping`` (N·m·s/rad of the joint whose child is ``link``).
        """

    @abstractmethod
    def load_urdf(
        self,
        name: str,
        urdf: str,
        *,
        position: Sequence[float] = (0.0, 0.0, 0.0),
        orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        fixed_base: bool = False,
        scale: float = 1.0,
        self_collision: bool = False,
    ) -> int:
        """Load a URDF (see :meth:`resolve_urdf`) with its base link frame at ``position`` / ``orientation`` and
        register it under ``name``; returns the body id. Inertia comes from the file.

        Raises:
            UserError: The file is missing or cannot be loaded.
        """

    @abstractmethod
    def load_model(
        self,
        name: str,
        path: str,
        kind: str,
        *,
        position: Sequence[float] = (0.0, 0.0, 0.0),
        orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        fixed_base: bool = False,
        scale: float = 1.0,
    ) -> list[int]:
        """Load an SDF (``kind="sdf"``) or MJCF (``kind="mjcf"``) file: every model in it becomes a body.

        The first model is registered as ``name``, further ones as ``name_1``, ``name_2`` … Each keeps its
        placement relative to the first model's base; the first base's link frame is put at ``position`` /
        ``orientation``. ``fixed_base`` makes each base static. Returns the body ids.

        Raises:
            UserError: The file is missing, cannot be parsed, or holds no model.
        """

    @abstractmethod
    def mount(
        self,
        child: str,
        parent: str,
        link: int,
        *,
        position: Sequence[float] = (0.0, 0.0, 0.0),
        orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
        max_force: float = 10_000.0,
    ) -> int:
        """Attach ``child``'s base to ``parent``'s ``link`` rigidly (a tool on an arm's flange), the two not
        colliding with each other; record it in :attr:`mounts`.

        ``position`` / ``orientation`` place the child's base link frame in the parent link's frame. The child is
        first moved there. Returns an attachment id.
        """

    @abstractmethod
    def remove_body(self, name: str) -> None:
        """Remove a body from the simulation and the registry (counts in :attr:`removals`)."""

    # ----------------------------------------------------------------- bodies, links, joints (read)
    @abstractmethod
    def joints(self, body: str | int) -> list[JointInfo]:
        """Every joint of a body, in index order (joint ``i`` moves link ``i``)."""

    @abstractmethod
    def base_link_name(self, body: str | int) -> str:
        """Name of the base link (index -1) as written in the model file."""

    @abstractmethod
    def joint_parent(self, body: str | int, joint: int) -> int:
        """Index of the link joint ``joint`` hangs from (``-1`` = the base): walk it to get a link's chain."""

    @abstractmethod
    def mass(self, body: str | int, link: int = -1) -> float:
        """Mass of a body's base or link, kg (0 = static)."""

    @abstractmethod
    def dynamics(self, body: str | int, link: int = -1) -> dict[str, float]:
        """Contact and mass parameters of a base or link now: ``mass`` (kg), ``lateral_friction``,
        ``rolling_friction``, ``spinning_friction``, ``restitution`` (the keys :meth:`set_dynamics` takes)."""

    @abstractmethod
    def set_visual_rgba(self, body: str | int, rgba: Sequence[float], link: int = -1) -> None:
        """Recolour a base or link: ``(r, g, b, a)`` in 0..1 (what cameras see)."""

    @abstractmethod
    def visual_rgba(self, body: str | int) -> tuple[float, float, float, float] | None:
        """Colour ``(r, g, b, a)`` in 0..1 of the body's first visual shape, or None if it has none."""

    # ----------------------------------------------------------------- poses and motion
    @abstractmethod
    def pose(self, body: str | int, link: int = -1) -> Pose:
        """Pose of a body's base (``link = -1``) or one of its links in the **link frame** the model file defines:
        position (m, world frame) and orientation ``(x, y, z, w)``. Called every tick: keep it cheap."""

    @abstractmethod
    def com_pose(self, body: str | int, link: int = -1) -> Pose:
        """Pose of a body's base or link in its **centre-of-mass** (inertial) frame, metres, world frame."""

    @abstractmethod
    def link_offset(self, body: str | int) -> Pose | None:
        """The base's link frame seen from its centre-of-mass frame, or None when the two coincide
        (``pose = com_pose ∘ link_offset``)."""

    @abstractmethod
    def velocity(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Linear velocity (m/s) of a body's base centre of mass and its angular velocity (rad/s), world frame."""

    @abstractmethod
    def link_velocity(self, body: str | int, link: int) -> tuple[Vec3, Vec3]:
        """Linear (m/s, of the link's centre of mass) and angular (rad/s) velocity of a link, world frame."""

    @abstractmethod
    def body_states(self, bodies: Sequence[int]) -> list[tuple[Vec3, Quat, Vec3, Vec3]]:
        """Per body: base link-frame position and orientation (as :meth:`pose`), linear and angular velocity (as
        :meth:`velocity`), in one call (a sensor reads many bodies every tick)."""

    @abstractmethod
    def set_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None = None) -> None:
        """Teleport a body's base so that its link frame is at ``position`` / ``orientation`` (None: keep it);
        velocity zeroed. For set-up and tests, not for control."""

    @abstractmethod
    def set_com_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float]) -> None:
        """Teleport a body's base so that its **centre-of-mass** frame (as :meth:`com_pose` reports it) is at
        ``position`` / ``orientation``; velocity kept. For set-up and carried cargo, not for control."""

    @abstractmethod
    def aabb(self, body: str | int, link: int = -1) -> tuple[Vec3, Vec3]:
        """Axis-aligned bounding box ``(min, max)`` of a body's link (``-1`` = base), metres, world frame."""

    @abstractmethod
    def body_aabb(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Bounding box ``(min, max)`` of a whole body (all links), metres, world frame."""

    @abstractmethod
    def apply_force(
        self, body: str | int, force: Sequence[float], *, position: Sequence[float] | None = None, link: int = -1
    ) -> None:
        """Apply a force (N, world frame) at a world point (default: the link's origin) for the next step."""

    # ----------------------------------------------------------------- joints: state and motors
    @abstractmethod
    def joint_states(self, body: int, joints: Sequence[int]) -> Sequence[JointState]:
        """State of each joint in ``joints`` (indices), in that order, after the last physics step, laid out as
        :class:`JointState` (read by index). Called every tick by controllers: keep it cheap."""

    @abstractmethod
    def reset_joint(self, body: int, joint: int, position: float, velocity: float | None = None) -> None:
        """Set a joint's position (and velocity, default 0) at once, bypassing dynamics. For set-up and resets."""

    @abstractmethod
    def set_joint_motor(
        self,
        body: int,
        joint: int,
        mode: MotorMode,
        *,
        target_position: float | None = None,
        target_velocity: float | None = None,
        force: float | None = None,
        max_velocity: float | None = None,
        position_gain: float | None = None,
    ) -> None:
        """Drive one joint. ``position``: a PD motor towards ``target_position`` (and ``target_velocity``, default
        0) with at most ``force`` (N·m or N), optionally capped at ``max_velocity``; ``position_gain`` is the
        engine's normalised gain (PyBullet's ``positionGain``, default 0.1). ``velocity``: reach
        ``target_velocity`` with at most ``force`` (``force = 0`` switches the joint's motor off: a passive
        joint). ``torque``: apply ``force`` for the next step only. Omitted values take the engine's defaults.
        The motor keeps its target until the next call."""

    @abstractmethod
    def set_joint_motors(
        self,
        body: int,
        joints: Sequence[int],
        mode: MotorMode,
        *,
        target_positions: Sequence[float] | None = None,
        target_velocities: Sequence[float] | None = None,
        forces: Sequence[float] | None = None,
        position_gains: Sequence[float] | None = None,
        velocity_gains: Sequence[float] | None = None,
    ) -> None:
        """:meth:`set_joint_motor` for many joints in one call (lists aligned with ``joints``); in ``torque``
        mode ``forces`` are the torques. No velocity cap here (use :meth:`set_joint_motor`)."""

    @abstractmethod
    def enable_joint_wrench(self, body: int, joint: int, enabled: bool = True) -> None:
        """Switch measuring a joint's reaction wrench (:attr:`JointState.reaction`) on or off."""

    @abstractmethod
    def wrench_frame(self, body: int, joint: int) -> tuple[float, ...]:
        """Rotation matrix (9 floats, row by row, world from frame) of the frame a joint's
        :attr:`JointState.reaction` is given in, as of the last physics step (when the wrench was measured)."""

    @abstractmethod
    def kinematic_chain(self, body: int, link: int) -> list[ChainFrame | ChainJoint]:
        """The frames from the world to ``link``'s link frame, for forward kinematics in numpy (the base must not
        move while it is used): start at the world frame, apply each :class:`ChainFrame`'s fixed transform and
        each :class:`ChainJoint`'s motion in order; the result is ``link``'s link frame at those joint values.
        The first entry is a :class:`ChainFrame` (the base's pose now)."""

    @abstractmethod
    def inverse_kinematics(
        self,
        body: int,
        link: int,
        position: Sequence[float],
        orientation: Sequence[float],
        *,
        seed: Sequence[float],
        damping: Sequence[float],
        iterations: int,
        tolerance: float,
    ) -> list[float] | None:
        """The engine's own IK for ``link``'s link frame at a world pose: one value per movable joint of the body
        (index order), started from ``seed`` (same layout), damped least squares with per-joint ``damping``, at
        most ``iterations`` iterations, stopping below ``tolerance`` (m). Unchecked: the caller verifies the answer.
        None when the engine has no IK of its own (the caller then solves with :meth:`kinematic_chain`)."""

    @abstractmethod
    def jacobian(self, body: int, link: int, positions: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Linear (3 x n, m/rad) and angular (3 x n) Jacobian of ``link``'s link-frame origin (as :meth:`pose` gives
        it), world frame, at the movable joints' ``positions`` (n, index order): columns are the movable joints in
        index order."""

    # ----------------------------------------------------------------- contacts, attachments
    @abstractmethod
    def contacts(
        self, body: int, other: int | None = None, *, link: int | None = None, other_link: int | None = None
    ) -> list[Contact]:
        """Contact points of ``body`` (only its ``link`` if given) with everything (or only ``other``, only its
        ``other_link``) after the last physics step. Called every tick by sensors: keep it cheap."""

    @abstractmethod
    def attach(
        self,
        parent: int,
        parent_link: int,
        child: int,
        *,
        position: Sequence[float] | None = None,
        max_force: float | None = None,
    ) -> int:
        """Hold ``child``'s base rigidly to ``parent``'s ``parent_link`` (a suction cup, a bin) and return an
        attachment id for :meth:`detach`.

        ``position`` None keeps the pose the two have now relative to each other; else the child's centre of mass
        is held at ``position`` (m) in the parent link's centre-of-mass frame, orientations aligned. ``max_force``
        (N) bounds the force holding it (None: the engine's default)."""

    @abstractmethod
    def couple_joints(self, body: int, leader: int, follower: int, ratio: float, *, erp: float,
                      max_force: float) -> int:
        """Tie joint ``follower`` to joint ``leader`` of the same body (a URDF ``<mimic>``, a gear): follower
        position = ``ratio`` × leader position, enforced with error reduction ``erp`` (0..1) and at most
        ``max_force``. Returns an attachment id for :meth:`detach`."""

    @abstractmethod
    def detach(self, attachment: int) -> None:
        """Remove an attachment made by :meth:`attach` or :meth:`couple_joints`."""

    @abstractmethod
    def joined(self, a: int, b: int) -> bool:
        """True if an attachment or mount joins bodies ``a`` and ``b`` directly."""

    @abstractmethod
    def disable_collisions(self, body: int) -> None:
        """Make every link of a body collide with nothing (carried cargo, a goal marker); it still moves with its
        attachments."""

    @abstractmethod
    def penetration(self, a: int, b: int) -> float:
        """How deep bodies ``a`` and ``b`` interpenetrate now, metres (0 when apart or just touching)."""

    def clashes(self, body: int, joints: Sequence[int], positions: Sequence[float], *,
                carried: Sequence[tuple[int, int, Pose]] = (), skip: Collection[int] = (),
                margin: float = 0.0) -> list[Clash]:
        """What would be closer than ``margin`` (m) if ``body``'s ``joints`` were at ``positions`` (rad or m) and
        each carried body ``(id, link, pose)`` sat at ``pose`` (its centre-of-mass frame in ``body``'s ``link``'s
        link frame, as held): the arm and the carried bodies against every other body not in ``skip``. The arm
        against itself and against what it carries is not asked. Nothing is stepped: the world is left exactly as
        it was (a motion planner's collision check).

        Raises:
            UserError: This engine cannot answer it.
        """
        raise UserError(f"the {self.engine} engine cannot check arm configurations for collisions")

    # ----------------------------------------------------------------- rays, cameras
    @abstractmethod
    def ray_caster(self, *, skip: Collection[int] = (), see_hidden: bool = True, mask: int = -1,
                   num_threads: int = 1, analytic: bool = True) -> RayCaster:
        """A :class:`RayCaster` for this world. ``skip``: bodies the rays never report (hide them first with
        :meth:`hide_from_rays`, so that they cost nothing). ``see_hidden=False``: rays pass through hidden bodies.
        ``mask``: PyBullet collision-filter mask of the rays (-1: every group; engines without groups ignore it).
        ``num_threads``: threads the engine may use per batch. ``analytic``: allow the engine's shortcuts that give
        the same answers (False: the reference path)."""

    @abstractmethod
    def hide_from_rays(self, body: int) -> None:
        """Let rays of a caster made with ``see_hidden=False`` pass through a body (a lidar's own robot) without
        changing the body's collisions."""

    @abstractmethod
    def view_matrix(self, eye: Sequence[float], target: Sequence[float], up: Sequence[float]) -> tuple[float, ...]:
        """OpenGL view matrix (16 floats, column-major) of a camera at ``eye`` looking at ``target`` (m, world)."""

    @abstractmethod
    def projection_matrix(self, fov_deg: float, aspect: float, near: float, far: float) -> tuple[float, ...]:
        """OpenGL projection matrix (16 floats, column-major): vertical field of view in degrees, width/height,
        near and far planes in metres."""

    @abstractmethod
    def image_sample_offset(self, renderer: str) -> float:
        """Where ``renderer`` samples a pixel: 0.0 = its corner (PyBullet's TinyRenderer), 0.5 = its centre."""

    @abstractmethod
    def render(
        self,
        width: int,
        height: int,
        view: Sequence[float],
        projection: Sequence[float],
        *,
        near: float,
        far: float,
        segmentation: bool = True,
        renderer: str = "tiny",
    ) -> RenderedImage:
        """Render one image with the given matrices (see :meth:`view_matrix`, :meth:`projection_matrix`; ``near``
        and ``far`` as in the projection). ``renderer``: ``"tiny"`` (software) or ``"opengl"`` (hardware, GUI
        only: headless engines fall back to software). Extra options from :attr:`render_options` apply."""

    # ----------------------------------------------------------------- pose arithmetic (the engine's own)
    @abstractmethod
    def multiply_transforms(self, position_a: Sequence[float], orientation_a: Sequence[float],
                            position_b: Sequence[float], orientation_b: Sequence[float]) -> Pose:
        """Compose two poses: frame B given in frame A, A in the world -> B in the world."""

    @abstractmethod
    def invert_transform(self, position: Sequence[float], orientation: Sequence[float]) -> Pose:
        """The inverse of a pose."""

    @abstractmethod
    def quaternion_from_euler(self, rpy: Sequence[float]) -> Quat:
        """Quaternion of roll, pitch, yaw in radians (fixed axes x, y, z)."""

    @abstractmethod
    def euler_from_quaternion(self, quaternion: Sequence[float]) -> Vec3:
        """Roll, pitch, yaw (radians) of a quaternion."""

    @abstractmethod
    def matrix_from_quaternion(self, quaternion: Sequence[float]) -> tuple[float, ...]:
        """3x3 rotation matrix of a quaternion, 9 floats row by row."""

    # ----------------------------------------------------------------- GUI: drawing, keys
    @abstractmethod
    def debug_line(
        self, start: Sequence[float], end: Sequence[float], rgb: Sequence[float], *, lifetime: float = 0.0
    ) -> None:
        """Draw a line in the viewer (no-op headless). ``lifetime`` in seconds, 0 = until removed."""

    @contextmanager
    def drawing(self) -> Iterator[None]:
        """Group many :meth:`debug_line` calls (the viewer may pause rendering meanwhile)."""
        yield

    @abstractmethod
    def key_events(self) -> Mapping[int, int]:
        """Keys that changed or are held since the last call (viewer only; empty headless): key code (``ord``
        of a lower-case character, or :data:`KEY_UP` …) -> flags (:data:`KEY_DOWN` | :data:`KEY_TRIGGERED` |
        :data:`KEY_RELEASED`)."""

    # ----------------------------------------------------------------- episodes, lifetime
    @abstractmethod
    def snapshot(self) -> dict[str, Any]:
        """Every registered body's state (base pose and velocity, joint states), for :meth:`restore`."""

    @abstractmethod
    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put every body of a :meth:`snapshot` back exactly (no contact state carried over), and the clock to
        tick 0: the next episode runs as one after a fresh build."""

    @property
    def closed(self) -> bool:
        """True once :meth:`close` ran (engine handles are gone)."""
        return self.client is None

    @abstractmethod
    def close(self) -> None:
        """Release the engine. Safe to call twice."""

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
