"""The World: one PyBullet client, a registry of named bodies, the sim clock and the run's random generator.

Units are SI throughout: metres, kilograms, seconds, newtons, radians (degrees only where a name says ``_deg``).
Positions are world frame ``(x, y, z)``; quaternions are PyBullet order ``(x, y, z, w)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import LookupNameError, UserError
from robokit.process.quiet import quiet_stdout

with quiet_stdout():  # pybullet prints its build time on import and argv[0] on connect, to C stdout
    import pybullet as p
    import pybullet_data
    from pybullet_utils.bullet_client import BulletClient

DATA_DIR = Path(__file__).resolve().parents[1] / "data"
"""URDFs and meshes bundled with robokit (searched after the config's folder and ``pybullet_data``)."""

JOINT_TYPES = {
    p.JOINT_REVOLUTE: "revolute",
    p.JOINT_PRISMATIC: "prismatic",
    p.JOINT_SPHERICAL: "spherical",
    p.JOINT_PLANAR: "planar",
    p.JOINT_FIXED: "fixed",
}

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


@dataclass(frozen=True)
class JointInfo:
    """One joint of a multibody, as read from the URDF (lesson 02's joint table).

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


_UNKNOWN: Any = object()
"""Not looked up yet (a cache sentinel)."""


def to_quaternion(rpy_deg: Sequence[float] | None = None, quaternion: Sequence[float] | None = None) -> Quat:
    """Turn roll/pitch/yaw in degrees, or a quaternion ``(x, y, z, w)``, into a unit quaternion."""
    if quaternion is not None:
        q = np.asarray(quaternion, dtype=float)
        q = q / np.linalg.norm(q)
        return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
    r, pch, y = (math.radians(a) for a in (rpy_deg or (0.0, 0.0, 0.0)))
    q2 = p.getQuaternionFromEuler((r, pch, y))
    return (q2[0], q2[1], q2[2], q2[3])


def yaw_of(quaternion: Sequence[float]) -> float:
    """Yaw (rotation about +z, radians, in (-pi, pi]) of a quaternion ``(x, y, z, w)``."""
    x, y, z, w = quaternion
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


_BOX_TRIANGLES = [
    0, 1, 2, 1, 3, 2,  4, 6, 5, 5, 6, 7,  0, 4, 1, 1, 4, 5,
    2, 3, 6, 3, 7, 6,  0, 2, 4, 2, 6, 4,  1, 5, 3, 3, 5, 7,
]
"""The 12 triangles of a box whose corner ``i`` has signs ``(x, y, z) = bits (4, 2, 1)`` of ``i``, facing out."""


def _box_vertices(half: Sequence[float]) -> list[list[float]]:
    """The 8 corners of a box with the given half extents, in the order :data:`_BOX_TRIANGLES` uses."""
    hx, hy, hz = half
    return [[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]


class _Client(BulletClient):  # type: ignore[misc]
    """A BulletClient that binds each pybullet function to its client id once, not on every attribute access."""

    def __getattr__(self, name: str) -> Any:
        attribute = super().__getattr__(name)
        if not name.startswith("_"):  # bound functions and constants alike never change
            self.__dict__[name] = attribute
        return attribute


class World:
    """Owns one PyBullet client (DIRECT by default), the named bodies in it, the clock and the RNG.

    Two Worlds in one process are fully independent: every call goes through this instance's own
    :class:`BulletClient`, never the module-global ``pybullet`` connection.

    Args:
        gui: Open the OpenGL GUI instead of the headless DIRECT engine.
        time_step: Physics step in seconds (default 1/240 s).
        gravity: Gravity vector in m/s², world frame.
        solver_iterations: Constraint solver iterations per step.
        seed: Seed of the run's :class:`numpy.random.Generator`, the only source of randomness.
        base_dir: Folder that relative URDF paths are resolved against (the config file's folder).
    """

    def __init__(
        self,
        *,
        gui: bool = False,
        time_step: float = 1.0 / 240.0,
        gravity: Sequence[float] = (0.0, 0.0, -9.81),
        solver_iterations: int = 50,
        seed: int = 0,
        base_dir: str | Path = ".",
    ) -> None:
        self.gui = gui
        self.time_step = float(time_step)
        self.seed = int(seed)
        self.base_dir = Path(base_dir)
        self._rng: np.random.Generator | None = None
        self.tick = 0
        with quiet_stdout():
            try:
                self.client: Any = _Client(connection_mode=p.GUI if gui else p.DIRECT)
            except p.error as exc:
                raise UserError(f"could not start PyBullet ({'GUI: is a display available?' if gui else exc})") from exc
        self._bodies: dict[str, int] = {}
        self.mounts: dict[int, int] = {}
        """Mounted body id -> the body id it is mounted on (see :meth:`mount`)."""
        self._names: dict[int, str] = {}
        self._joint_cache: dict[int, list[JointInfo]] = {}
        self._com_to_link: dict[int, Any] = {}
        self._cid = int(self.client._client)
        self.removals = 0
        """Bodies removed so far: lets components cache id lookups until it changes."""
        self.mesh_boxes: dict[int, tuple[float, float, float]] = {}
        """Static boxes built as triangle meshes (``mesh_collision``): body id -> half extents (m), centred on the
        base frame. PyBullet cannot give a mesh's triangles back; the lidar intersects these boxes itself."""
        self.render_options: dict[str, Any] = {}
        """Extra ``getCameraImage`` arguments every camera passes (``lightDirection``: set by ``[randomize]``)."""
        self.client.setAdditionalSearchPath(pybullet_data.getDataPath())
        self.client.setGravity(*gravity)
        self.client.setPhysicsEngineParameter(fixedTimeStep=self.time_step, numSolverIterations=solver_iterations)
        if gui:
            self.client.configureDebugVisualizer(p.COV_ENABLE_GUI, 0)

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
    def cid(self) -> int:
        """The client id, for hot loops that call ``pybullet.f(..., physicsClientId=world.cid)`` directly."""
        return self._cid

    # ----------------------------------------------------------------- clock
    @property
    def time(self) -> float:
        """Simulated seconds since the start of the run (``tick * time_step``)."""
        return self.tick * self.time_step

    @property
    def physics_hz(self) -> float:
        """Physics steps per simulated second."""
        return 1.0 / self.time_step

    def step(self) -> None:
        """Advance physics by one step. Only the scheduler calls this."""
        self.client.stepSimulation()
        self.tick += 1

    # ----------------------------------------------------------------- bodies
    def _register(self, name: str, body_id: int) -> int:
        if name in self._bodies:
            raise UserError(f"a body named {name!r} already exists")
        self._bodies[name] = body_id
        self._names[body_id] = name
        return body_id

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
        """Create a box (``size`` = full edge lengths), sphere (``radius``) or cylinder (``radius``, ``height``).

        A ``mass`` of 0 makes the body static. ``mesh_collision`` builds a static box's collision shape as a
        triangle mesh: contacts behave alike, and ray casts (lidar) against it cost about 40 % less.
        Returns the body id and registers it under ``name``.
        """
        c = self.client
        if shape == "box":
            half = [s / 2.0 for s in size]
            if mesh_collision:
                if mass != 0:
                    raise UserError("a triangle-mesh collision shape needs mass = 0 (static bodies only)")
                col = c.createCollisionShape(p.GEOM_MESH, vertices=_box_vertices(half), indices=_BOX_TRIANGLES)
                mesh_half = (half[0], half[1], half[2])
            else:
                col = c.createCollisionShape(p.GEOM_BOX, halfExtents=half)
            vis = c.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=list(rgba))
        elif shape == "sphere":
            col = c.createCollisionShape(p.GEOM_SPHERE, radius=radius)
            vis = c.createVisualShape(p.GEOM_SPHERE, radius=radius, rgbaColor=list(rgba))
        elif shape == "cylinder":
            col = c.createCollisionShape(p.GEOM_CYLINDER, radius=radius, height=height)
            vis = c.createVisualShape(p.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=list(rgba))
        else:
            raise UserError(f"unknown shape {shape!r}; valid: box, cylinder, sphere")
        body = c.createMultiBody(
            baseMass=mass,
            baseCollisionShapeIndex=col,
            baseVisualShapeIndex=vis,
            basePosition=list(position),
            baseOrientation=list(orientation),
        )
        self._register(name, body)
        if shape == "box" and mesh_collision:
            self.mesh_boxes[body] = mesh_half
        self.set_dynamics(
            body,
            lateral_friction=lateral_friction,
            rolling_friction=rolling_friction,
            spinning_friction=spinning_friction,
            restitution=restitution,
            linear_damping=linear_damping,
            angular_damping=angular_damping,
        )
        return body

    def set_dynamics(self, body: int | str, link: int = -1, **params: float | None) -> None:
        """Set contact and damping parameters of one link (``-1`` = base); ``None`` values are left alone.

        Keyword names are snake_case versions of ``changeDynamics`` arguments, e.g. ``lateral_friction``.
        """
        names = {
            "lateral_friction": "lateralFriction",
            "rolling_friction": "rollingFriction",
            "spinning_friction": "spinningFriction",
            "restitution": "restitution",
            "linear_damping": "linearDamping",
            "angular_damping": "angularDamping",
            "mass": "mass",
        }
        kwargs = {names[k]: float(v) for k, v in params.items() if v is not None}
        if kwargs:
            self.client.changeDynamics(self.body(body), link, **kwargs)

    def resolve_urdf(self, urdf: str) -> str:
        """Find a model file (URDF, SDF or MJCF): a path relative to the config folder, robokit's bundled data,
        or a ``pybullet_data`` name.

        Raises:
            UserError: The file exists in none of those places (the message lists where it looked).
        """
        candidates = [self.base_dir / urdf, DATA_DIR / urdf, Path(pybullet_data.getDataPath()) / urdf]
        if Path(urdf).is_absolute():
            candidates = [Path(urdf)]
        for cand in candidates:
            if cand.is_file():
                return str(cand.resolve())
        looked = ", ".join(str(c.parent) for c in candidates)
        kind = {".sdf": "SDF", ".xml": "MJCF", ".mjcf": "MJCF"}.get(Path(urdf).suffix.lower(), "URDF")
        raise UserError(f"{kind} {urdf!r} not found (looked in {looked})")

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
        """Load a URDF (see :meth:`resolve_urdf`) and register it under ``name``; returns the body id."""
        path = self.resolve_urdf(urdf)
        flags = p.URDF_USE_INERTIA_FROM_FILE
        if self_collision:
            flags |= p.URDF_USE_SELF_COLLISION
        try:
            body = self.client.loadURDF(
                path, list(position), list(orientation), useFixedBase=fixed_base, globalScaling=scale, flags=flags
            )
        except p.error as exc:
            raise UserError(f"URDF {urdf!r} could not be loaded: {exc}") from exc
        return self._register(name, body)

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

        The first model is registered as ``name``, further ones as ``name_1``, ``name_2`` … Each model keeps the
        placement the file gives it relative to the first model's base, and the whole file is moved so that the
        first base sits at ``position`` / ``orientation`` (world frame). ``fixed_base`` pins each base in place
        (SDF and MJCF loaders have no fixed-base flag: the base is made static, mass 0). ``scale`` is SDF only.

        Raises:
            UserError: The file is missing, cannot be parsed, or holds no model.
        """
        resolved = self.resolve_urdf(path)
        label = kind.upper()
        try:
            if kind == "sdf":
                ids = list(self.client.loadSDF(resolved, globalScaling=scale))
            else:
                ids = list(self.client.loadMJCF(resolved))
        except p.error as exc:
            raise UserError(f"{label} {path!r} could not be loaded: {exc}") from exc
        if not ids:
            raise UserError(f"{label} {path!r} holds no model")
        c = self.client

        def link_frame(body: int) -> tuple[Any, Any]:
            # pybullet reports (and sets) a base by its centre-of-mass frame; the model's base frame is that
            # composed with the inverse of the base's inertial offset.
            com, inertial = c.getBasePositionAndOrientation(body), c.getDynamicsInfo(body, -1)[3:5]
            return c.multiplyTransforms(*com, *c.invertTransform(*inertial))

        inv_first = c.invertTransform(*link_frame(ids[0]))
        for i, body in enumerate(ids):
            rel = c.multiplyTransforms(*inv_first, *link_frame(body))
            new_frame = c.multiplyTransforms(list(position), list(orientation), *rel)
            inertial = c.getDynamicsInfo(body, -1)[3:5]
            c.resetBasePositionAndOrientation(body, *c.multiplyTransforms(*new_frame, *inertial))
            if fixed_base:
                c.changeDynamics(body, -1, mass=0.0)
            self._register(name if i == 0 else f"{name}_{i}", body)
        return ids

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
        """Attach ``child``'s base to ``parent``'s ``link`` with a fixed joint (a tool on an arm's flange).

        ``position`` / ``orientation`` place the child's base frame in the parent link's frame (metres, x y z w).
        The child is first moved there, so the constraint starts satisfied. Returns the constraint id.
        """
        c = self.client
        pid, cid = self.body(parent), self.body(child)
        lpos, lorn = self.pose(pid, link)
        wpos, worn = c.multiplyTransforms(lpos, lorn, list(position), list(orientation))
        child_inertial = c.getDynamicsInfo(cid, -1)[3:5]
        # pybullet places a base by its centre-of-mass frame: the link frame composed with the inertial offset.
        c.resetBasePositionAndOrientation(cid, *c.multiplyTransforms(wpos, worn, *child_inertial))
        # The constraint's parent frame is given in the link's centre-of-mass frame: convert from the link frame.
        if link == -1:
            inertial = c.getDynamicsInfo(pid, -1)[3:5]
        else:
            inertial = c.getLinkState(pid, link)[2:4]
        ipos, iorn = c.invertTransform(inertial[0], inertial[1])
        fpos, forn = c.multiplyTransforms(ipos, iorn, list(position), list(orientation))
        cpos, corn = c.invertTransform(child_inertial[0], child_inertial[1])
        constraint = c.createConstraint(pid, link, cid, -1, c.JOINT_FIXED, [0, 0, 0], fpos, cpos,
                                        parentFrameOrientation=forn, childFrameOrientation=corn)
        c.changeConstraint(constraint, maxForce=max_force)
        # The tool sits against the flange: those two must not collide (it would fight the joint).
        c.setCollisionFilterPair(pid, cid, link, -1, 0)
        self.mounts[cid] = pid
        return int(constraint)

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

    def remove_body(self, name: str) -> None:
        """Remove a body from the simulation and the registry."""
        body = self.body(name)
        self.client.removeBody(body)
        del self._bodies[name]
        del self._names[body]
        self._joint_cache.pop(body, None)
        self._com_to_link.pop(body, None)
        self.mesh_boxes.pop(body, None)
        self.removals += 1

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

    # ----------------------------------------------------------------- joints and links
    def joints(self, body: str | int) -> list[JointInfo]:
        """Every joint of a body, in index order (cached: joint layout never changes)."""
        bid = self.body(body)
        if bid not in self._joint_cache:
            infos = []
            for i in range(self.client.getNumJoints(bid)):
                j = self.client.getJointInfo(bid, i)
                infos.append(
                    JointInfo(
                        index=i,
                        name=j[1].decode(),
                        type=JOINT_TYPES.get(j[2], str(j[2])),
                        lower=float(j[8]),
                        upper=float(j[9]),
                        max_force=float(j[10]),
                        max_velocity=float(j[11]),
                        damping=float(j[6]),
                        friction=float(j[7]),
                        child_link=j[12].decode(),
                    )
                )
            self._joint_cache[bid] = infos
        return self._joint_cache[bid]

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

    def base_link_name(self, body: str | int) -> str:
        """Name of the base link (index -1) as written in the URDF."""
        return str(self.client.getBodyInfo(self.body(body))[0].decode())

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

    # ----------------------------------------------------------------- state
    def pose(self, body: str | int, link: int = -1) -> tuple[Vec3, Quat]:
        """Pose of a body's base (``link = -1``) or one of its links in the **link frame** the URDF (or SDF)
        defines: position (m, world frame) and orientation ``(x, y, z, w)``.

        This is the frame mount offsets, link names and ``position = [...]`` in a config refer to. PyBullet's
        ``getBasePositionAndOrientation`` gives the base's *centre-of-mass* frame instead (the link frame moved by
        the URDF's ``<inertial><origin>``, 2 cm on the bundled diffbot); :meth:`com_pose` gives that one.
        """
        bid = self._bodies.get(body) if isinstance(body, str) else None  # fast path: called every tick
        if bid is None:
            bid = self.body(body)
        if link == -1:
            pos, orn = self.client.getBasePositionAndOrientation(bid)
            offset = self._com_to_link.get(bid, _UNKNOWN)
            if offset is _UNKNOWN:
                offset = self._com_to_link[bid] = self.link_offset(bid)
            if offset is None:
                return pos, orn
            return self.client.multiplyTransforms(pos, orn, *offset)  # type: ignore[no-any-return]
        state = self.client.getLinkState(bid, link, computeForwardKinematics=True)
        return state[4], state[5]

    def com_pose(self, body: str | int, link: int = -1) -> tuple[Vec3, Quat]:
        """Pose of a body's base or link in its **centre-of-mass** (inertial) frame: where forces act and what
        PyBullet's ``getBasePositionAndOrientation`` / ``getLinkState(...)[0:2]`` return. Metres, world frame,
        ``(x, y, z, w)``. For most uses (mounting, goals, what a config's positions mean) use :meth:`pose`.
        """
        bid = self.body(body)
        if link == -1:
            return self.client.getBasePositionAndOrientation(bid)  # type: ignore[no-any-return]
        state = self.client.getLinkState(bid, link, computeForwardKinematics=True)
        return state[0], state[1]

    def link_offset(self, body: str | int) -> tuple[Vec3, Quat] | None:
        """The base's link frame seen from its centre-of-mass frame (the inverse of the URDF's inertial origin), or
        None when the two coincide (primitives, most objects). ``pose = com_pose ∘ link_offset``."""
        ipos, iorn = self.client.getDynamicsInfo(self.body(body), -1)[3:5]
        if max(abs(v) for v in ipos) < 1e-12 and abs(abs(iorn[3]) - 1.0) < 1e-12:
            return None
        return self.client.invertTransform(ipos, iorn)  # type: ignore[no-any-return]

    def velocity(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Linear (m/s) velocity of a body's base centre of mass and its angular velocity (rad/s), world frame."""
        bid = self._bodies.get(body) if isinstance(body, str) else None
        return self.client.getBaseVelocity(self.body(body) if bid is None else bid)  # type: ignore[no-any-return]

    def set_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None = None) -> None:
        """Teleport a body's base so that its **link frame** (as :meth:`pose` reports it) is at ``position`` /
        ``orientation`` (velocity is zeroed). For set-up and tests, not for control."""
        bid = self.body(body)
        orn = orientation if orientation is not None else self.pose(bid)[1]
        inertial = self.client.getDynamicsInfo(bid, -1)[3:5]
        com_pos, com_orn = self.client.multiplyTransforms(list(position), list(orn), *inertial)
        self.client.resetBasePositionAndOrientation(bid, com_pos, com_orn)
        self.client.resetBaseVelocity(bid, [0, 0, 0], [0, 0, 0])

    def aabb(self, body: str | int, link: int = -1) -> tuple[Vec3, Vec3]:
        """Axis-aligned bounding box ``(min, max)`` of a body's link (``-1`` = base), metres, world frame."""
        lo, hi = self.client.getAABB(self.body(body), link)
        return tuple(lo), tuple(hi)  # type: ignore[return-value]

    def body_aabb(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Bounding box of a whole body (all links). Plain Python, no numpy: the lidar calls it on every scan."""
        bid = self.body(body)
        aabb = self.client.getAABB
        boxes = [aabb(bid, link) for link in range(-1, len(self.joints(bid)))]
        lo = tuple(min(b[0][i] for b in boxes) for i in range(3))
        hi = tuple(max(b[1][i] for b in boxes) for i in range(3))
        return lo, hi  # type: ignore[return-value]

    def apply_force(
        self,
        body: str | int,
        force: Sequence[float],
        *,
        position: Sequence[float] | None = None,
        link: int = -1,
    ) -> None:
        """Apply a force (N, world frame) at a world point (default: the link's centre of mass) for one step."""
        bid = self.body(body)
        at = position if position is not None else self.pose(bid, link)[0]
        self.client.applyExternalForce(bid, link, list(force), list(at), p.WORLD_FRAME)

    def debug_line(
        self, start: Sequence[float], end: Sequence[float], rgb: Sequence[float], *, lifetime: float = 0.0
    ) -> None:
        """Draw a line in the GUI (no-op headless). ``lifetime`` in seconds, 0 = until removed."""
        if self.gui:
            self.client.addUserDebugLine(list(start), list(end), list(rgb), lineWidth=1.5, lifeTime=lifetime)

    # ----------------------------------------------------------------- randomness
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

    # ----------------------------------------------------------------- episodes (robokit.gym)
    def snapshot(self) -> dict[str, Any]:
        """Every registered body's base pose and velocity and joint states, for :meth:`restore` (a cheap reset).

        Also makes Bullet sort its overlapping pairs, so that contacts are solved in the same order after a
        restore whatever the broadphase's history (without it, episodes after the first differ in contact-rich
        scenes).
        """
        c, out = self.client, {}
        c.setPhysicsEngineParameter(deterministicOverlappingPairs=1)
        for name, bid in self._bodies.items():
            n = c.getNumJoints(bid)
            joints = [s[:2] for s in c.getJointStates(bid, list(range(n)))] if n else []
            out[name] = (c.getBasePositionAndOrientation(bid), c.getBaseVelocity(bid), joints)
        return out

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put every body of a :meth:`snapshot` back, and the clock to tick 0.

        Contact points cached between bodies are dropped too (every body is moved out of reach of the others
        and collision detection runs once), so an episode after a restore starts exactly as one after a fresh
        build: no warm-started contact impulses carry over.
        """
        c = self.client
        far = 1.0e4
        for k, bid in enumerate(self._bodies.values()):
            c.resetBasePositionAndOrientation(bid, [far * (k + 1), far, far], [0.0, 0.0, 0.0, 1.0])
        c.performCollisionDetection()
        for name, ((pos, orn), (lin, ang), joints) in snapshot.items():
            bid = self._bodies[name]
            c.resetBasePositionAndOrientation(bid, pos, orn)
            c.resetBaseVelocity(bid, lin, ang)
            for i, (q, dq) in enumerate(joints):
                c.resetJointState(bid, i, q, dq)
        self.tick = 0

    # ----------------------------------------------------------------- lifetime
    def close(self) -> None:
        """Disconnect the client. Safe to call twice."""
        if self.client is not None:
            try:
                self.client.disconnect()
            except p.error:
                pass
            self.client = None

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
