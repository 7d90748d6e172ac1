"""The PyBullet engine: :class:`PyBulletWorld`, the World on one ``BulletClient`` (DIRECT by default, GUI on
request). Never the module-global ``pybullet`` connection: two worlds live side by side in one process.

Everything PyBullet-specific lives here (and in :mod:`robokit.engines.pybullet.rays`): its tuple layouts, its
centre-of-mass frames, its constants. The methods' contracts (units, frames) are the interface's
(:class:`robokit.engines.interface.World`).
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from robokit.engines.interface import (
    DATA_DIR,
    ChainFrame,
    ChainJoint,
    Clash,
    Contact,
    JointInfo,
    JointState,
    MotorMode,
    Pose,
    Quat,
    RayCaster,
    RenderedImage,
    Vec3,
    World,
    display_problem,
    yaw_of,
)
from robokit.errors import UserError
from robokit.process.quiet import quiet_stdout

with quiet_stdout():  # pybullet prints its build time on import and argv[0] on connect, to C stdout
    import pybullet as p
    import pybullet_data
    from pybullet_utils.bullet_client import BulletClient

__all__ = ["DATA_DIR", "JOINT_TYPES", "JointInfo", "PyBulletWorld", "Quat", "Vec3", "to_quaternion", "yaw_of"]

JOINT_TYPES = {
    p.JOINT_REVOLUTE: "revolute",
    p.JOINT_PRISMATIC: "prismatic",
    p.JOINT_SPHERICAL: "spherical",
    p.JOINT_PLANAR: "planar",
    p.JOINT_FIXED: "fixed",
}
_MODES = {"position": p.POSITION_CONTROL, "velocity": p.VELOCITY_CONTROL, "torque": p.TORQUE_CONTROL}
OWN_BODY_GROUP = 0x100
"""Collision group :meth:`PyBulletWorld.hide_from_rays` puts a body's links in (other collisions unchanged)."""

_UNKNOWN: Any = object()
"""Not looked up yet (a cache sentinel)."""
_KEPT = ("targetPosition", "targetVelocity", "force", "positionGain", "velocityGain",
         "targetPositions", "targetVelocities", "forces", "positionGains", "velocityGains")
"""A position or velocity command's arguments PyBullet sets at each command (to its defaults when not given)."""


def to_quaternion(rpy_deg: Sequence[float] | None = None, quaternion: Sequence[float] | None = None) -> Quat:
    """Turn roll/pitch/yaw in degrees, or a quaternion ``(x, y, z, w)``, into a unit quaternion."""
    if quaternion is not None:
        q = np.asarray(quaternion, dtype=float)
        q = q / np.linalg.norm(q)
        return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
    r, pch, y = (math.radians(a) for a in (rpy_deg or (0.0, 0.0, 0.0)))
    q2 = p.getQuaternionFromEuler((r, pch, y))
    return (q2[0], q2[1], q2[2], q2[3])


_BOX_TRIANGLES = [
    0, 1, 2, 1, 3, 2,  4, 6, 5, 5, 6, 7,  0, 4, 1, 1, 4, 5,
    2, 3, 6, 3, 7, 6,  0, 2, 4, 2, 6, 4,  1, 5, 3, 3, 5, 7,
]
"""The 12 triangles of a box whose corner ``i`` has signs ``(x, y, z) = bits (4, 2, 1)`` of ``i``, facing out."""


def _box_vertices(half: Sequence[float]) -> list[list[float]]:
    """The 8 corners of a box with the given half extents, in the order :data:`_BOX_TRIANGLES` uses."""
    hx, hy, hz = half
    return [[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]


class _Motor(NamedTuple):
    """A joint's last position or velocity command (see ``PyBulletWorld._motors``)."""

    mode: int
    """PyBullet's control mode."""
    args: dict[str, float]
    """Its arguments but ``maxVelocity``; a ``setJointMotorControlArray`` call's by their plural names, this joint's
    values."""
    cap: float | None
    """The last ``maxVelocity`` given to the joint (None: never)."""
    array: bool
    """Sent by ``setJointMotorControlArray``."""


def _fresh_motor_force(time_step: float) -> float:
    """The force (N or N m) a velocity motor command needs to give PyBullet's own motor of a fresh build, whose
    impulse per step is exactly 1 (PyBullet multiplies the force by the time step)."""
    force = 1.0 / time_step
    for _ in range(4):
        if force * time_step == 1.0:
            break
        force = math.nextafter(force, math.inf if force * time_step < 1.0 else -math.inf)
    return force


class _Client(BulletClient):  # type: ignore[misc]
    """A BulletClient that binds each pybullet function to its client id once, not on every attribute access."""

    def __getattr__(self, name: str) -> Any:
        attribute = super().__getattr__(name)
        if not name.startswith("_"):  # bound functions and constants alike never change
            self.__dict__[name] = attribute
        return attribute


def _version(package: str, module_file: str) -> str:
    """The installed version of ``package``, read from the name of its ``NAME-VERSION.dist-info`` folder beside the
    module (``importlib.metadata`` would cost every run's start-up a tenth more); "" for a build without metadata."""
    folder = os.path.dirname(module_file)
    prefix = f"{package}-"
    for entry in os.listdir(folder):
        if entry.startswith(prefix) and entry.endswith(".dist-info"):
            return entry[len(prefix):-len(".dist-info")]
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(package)
    except PackageNotFoundError:  # a build from source without metadata
        return ""


class PyBulletWorld(World):
    """The World on one PyBullet client (DIRECT by default, GUI on request); see :class:`World` for the arguments.

    Two PyBulletWorlds in one process are fully independent: every call goes through this instance's own
    :class:`BulletClient`, never the module-global ``pybullet`` connection.
    """

    engine = "pybullet"
    engine_version = _version("pybullet", p.__file__)

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
        super().__init__(gui=gui, time_step=time_step, gravity=gravity, solver_iterations=solver_iterations,
                         seed=seed, base_dir=base_dir, engine=engine)
        problem = self.window_problem() if gui else None
        if problem is not None:  # PyBullet ends the process when its window cannot open: say why instead
            raise UserError(f"PyBullet's GUI window cannot open: {problem}")
        with quiet_stdout():
            try:
                self.client: Any = _Client(connection_mode=p.GUI if gui else p.DIRECT)
            except p.error as exc:
                raise UserError(f"could not start PyBullet ({'GUI: is a display available?' if gui else exc})") from exc
        self._joint_cache: dict[int, list[JointInfo]] = {}
        self._com_to_link: dict[int, Any] = {}
        self._shape_copies: dict[int, list[tuple[int, Pose]]] = {}  # see _query_shapes
        self._wrench_shifts: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}  # see enable_joint_wrench
        self._cid = int(self.client._client)
        self._motors: dict[tuple[int, int], _Motor] = {}
        """(body, joint) -> the last position or velocity command sent to it and the last ``maxVelocity`` given
        (PyBullet keeps that one until another is given): what :meth:`restore` puts back. A joint not in it has
        PyBullet's own motor of a fresh build."""
        self._urdf_contents: dict[str, list[bytes]] = {}
        """URDF path -> the SHA-256 of each content it had when loaded, in order (see :meth:`load_urdf`)."""
        self.mesh_boxes: dict[int, tuple[float, float, float]] = {}
        """Static boxes built as triangle meshes (``mesh_collision``): body id -> half extents (m), centred on the
        base frame. PyBullet cannot give a mesh's triangles back; the ray caster intersects these boxes itself."""
        self.client.setAdditionalSearchPath(pybullet_data.getDataPath())
        self.client.setGravity(*gravity)
        # Bullet sorts its overlapping pairs from the build on: contacts are solved in the same order whatever the
        # broadphase's history, so a restored world (see restore) steps as a fresh one, and reading a snapshot
        # changes nothing
        self.client.setPhysicsEngineParameter(fixedTimeStep=self.time_step, numSolverIterations=solver_iterations,
                                              deterministicOverlappingPairs=1)
        if gui:
            self.client.configureDebugVisualizer(p.COV_ENABLE_GUI, 0)

    @classmethod
    def window_problem(cls) -> str | None:
        """On Linux PyBullet's window needs an X display: None if ``$DISPLAY`` opens, else why not (see
        :func:`~robokit.engines.interface.display_problem`)."""
        return display_problem()

    @property
    def cid(self) -> int:
        """The client id, for hot loops that call ``pybullet.f(..., physicsClientId=world.cid)`` directly."""
        return self._cid

    def step(self) -> None:
        """Advance physics by one step. Only the scheduler calls this."""
        self.client.stepSimulation()
        self.tick += 1

    # ----------------------------------------------------------------- bodies
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
            "friction_anchor": "frictionAnchor",
            "joint_damping": "jointDamping",
        }
        kwargs: dict[str, float | int] = {
            names[k]: (int(v) if k == "friction_anchor" else float(v)) for k, v in params.items() if v is not None}
        if kwargs:
            self.client.changeDynamics(self.body(body), link, **kwargs)

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
        """Load a URDF (see :meth:`resolve_urdf`) and register it under ``name``; returns the body id.

        PyBullet keeps a URDF it parsed under its path string for the client's life: a file rewritten on disk and
        loaded again under the same string would load as it was. Each content of a path (by its SHA-256) is loaded
        under its own spelling of that path (``dir/./name``, ``dir/././name``, ...: the same folder, so meshes beside
        it resolve alike), so the body built is always the file's content now."""
        path = self._spelling(self.resolve_urdf(urdf))
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

    def _spelling(self, path: str) -> str:
        """``path`` spelt once per content it has had in this world (see :meth:`load_urdf`; SDF and MJCF files
        alike)."""
        try:
            digest = hashlib.sha256(Path(path).read_bytes()).digest()
        except OSError:
            return path  # (PyBullet says what is wrong with it)
        seen = self._urdf_contents.setdefault(path, [])
        if digest not in seen:
            seen.append(digest)
        k = seen.index(digest)
        if k == 0:
            return path
        folder, name = os.path.split(path)
        return folder + "/." * k + "/" + name

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
        resolved = self._spelling(self.resolve_urdf(path))  # (PyBullet keeps these by path too: see load_urdf)
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

    def remove_body(self, name: str) -> None:
        """Remove a body from the simulation and the registry."""
        body = self.body(name)
        self.client.removeBody(body)
        self._unregister(name)
        self._joint_cache.pop(body, None)
        self._com_to_link.pop(body, None)
        self.mesh_boxes.pop(body, None)
        self._shape_copies.pop(body, None)
        for key in [k for k in self._motors if k[0] == body]:
            del self._motors[key]

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

    def base_link_name(self, body: str | int) -> str:
        """Name of the base link (index -1) as written in the URDF."""
        return str(self.client.getBodyInfo(self.body(body))[0].decode())

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

    def set_com_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float]) -> None:
        """``resetBasePositionAndOrientation`` (PyBullet places a base by its centre-of-mass frame)."""
        self.client.resetBasePositionAndOrientation(self.body(body), position, orientation)

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
        """Apply a force (N, world frame) at a world point (default: the link's origin) for one step."""
        bid = self.body(body)
        at = position if position is not None else self.pose(bid, link)[0]
        self.client.applyExternalForce(bid, link, list(force), list(at), p.WORLD_FRAME)

    def debug_line(
        self, start: Sequence[float], end: Sequence[float], rgb: Sequence[float], *, lifetime: float = 0.0
    ) -> None:
        """Draw a line in the GUI (no-op headless). ``lifetime`` in seconds, 0 = until removed."""
        if self.gui:
            self.client.addUserDebugLine(list(start), list(end), list(rgb), lineWidth=1.5, lifeTime=lifetime)

    # ----------------------------------------------------------------- interface additions: reads
    def joint_parent(self, body: str | int, joint: int) -> int:
        """Index of the link joint ``joint`` hangs from (``-1`` = base): field 16 of ``getJointInfo``."""
        return int(self.client.getJointInfo(self.body(body), joint)[16])

    def mass(self, body: str | int, link: int = -1) -> float:
        """Mass (kg) of a base or link: field 0 of ``getDynamicsInfo``."""
        return float(self.client.getDynamicsInfo(self.body(body), link)[0])

    def dynamics(self, body: str | int, link: int = -1) -> dict[str, float]:
        """Fields 0, 1, 6, 7, 5 of ``getDynamicsInfo``."""
        info = self.client.getDynamicsInfo(self.body(body), link)
        return {"mass": float(info[0]), "lateral_friction": float(info[1]), "rolling_friction": float(info[6]),
                "spinning_friction": float(info[7]), "restitution": float(info[5])}

    def set_visual_rgba(self, body: str | int, rgba: Sequence[float], link: int = -1) -> None:
        self.client.changeVisualShape(self.body(body), link, rgbaColor=rgba)

    def visual_rgba(self, body: str | int) -> tuple[float, float, float, float] | None:
        """Colour of the first visual shape (field 7 of ``getVisualShapeData``)."""
        shapes = self.client.getVisualShapeData(self.body(body))
        return tuple(shapes[0][7]) if shapes else None  # type: ignore[return-value]

    def link_velocity(self, body: str | int, link: int) -> tuple[Vec3, Vec3]:
        """Link velocity from ``getLinkState(computeLinkVelocity=True)`` (the link's centre of mass)."""
        s = self.client.getLinkState(self.body(body), link, computeLinkVelocity=True, computeForwardKinematics=True)
        return s[6], s[7]

    def body_states(self, bodies: Sequence[int]) -> list[tuple[Vec3, Quat, Vec3, Vec3]]:
        """Base poses and velocities of many bodies: pybullet's module functions with the client id (no bound
        method lookups: this runs every tick); bodies whose link frame is not their centre of mass through
        :meth:`pose`."""
        cid, pose, velocity, offsets = self._cid, p.getBasePositionAndOrientation, p.getBaseVelocity, self._com_to_link
        out = []
        for bid in bodies:
            offset = offsets.get(bid, _UNKNOWN)
            if offset is _UNKNOWN:
                offset = offsets[bid] = self.link_offset(bid)
            out.append((pose(bid, physicsClientId=cid) if offset is None else self.pose(bid))
                       + velocity(bid, physicsClientId=cid))
        return out

    # ----------------------------------------------------------------- interface additions: joints
    def joint_states(self, body: int, joints: Sequence[int]) -> Sequence[JointState]:
        """``getJointStates``: its tuples have :class:`JointState`'s layout. PyBullet gives a measured reaction in
        the child's centre-of-mass frame, torque about the centre of mass; it is handed back in the child link's
        frame, torque about the link's origin (the interface's frame, see :meth:`enable_joint_wrench`)."""
        states = self.client.getJointStates(body, joints)
        if not self._wrench_shifts:
            return states  # type: ignore[no-any-return]
        out = list(states)
        for i, joint in enumerate(joints):
            shift = self._wrench_shifts.get((body, joint))
            if shift is not None:
                rot, offset = shift
                r = states[i][2]
                force = rot @ np.asarray(r[:3], dtype=float)
                torque = rot @ np.asarray(r[3:], dtype=float) + np.cross(offset, force)
                out[i] = (states[i][0], states[i][1], (*force.tolist(), *torque.tolist()), states[i][3])
        return out

    def reset_joint(self, body: int, joint: int, position: float, velocity: float | None = None) -> None:
        if velocity is None:
            self.client.resetJointState(body, joint, position)
        else:
            self.client.resetJointState(body, joint, position, velocity)

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
        """``setJointMotorControl2`` with only the given arguments (PyBullet's defaults for the rest)."""
        kwargs: dict[str, float] = {}
        if target_position is not None:
            kwargs["targetPosition"] = target_position
        if target_velocity is not None:
            kwargs["targetVelocity"] = target_velocity
        if force is not None:
            kwargs["force"] = force
        if position_gain is not None:
            kwargs["positionGain"] = position_gain
        if max_velocity is not None:
            kwargs["maxVelocity"] = max_velocity
        self.client.setJointMotorControl2(body, joint, _MODES[mode], **kwargs)
        if mode != "torque":  # (a torque lasts one step)
            self._keep_motor(body, joint, _MODES[mode], kwargs)

    def _keep_motor(self, body: int, joint: int, mode: int, kwargs: dict[str, float], array: bool = False) -> None:
        """Note a position or velocity command for :meth:`restore` (see ``_motors``)."""
        key = (int(body), int(joint))
        cap = kwargs.get("maxVelocity")
        if cap is None or not cap > 0.0:  # (PyBullet takes a max velocity only above 0)
            cap = self._motors[key].cap if key in self._motors else None
        self._motors[key] = _Motor(mode, {k: v for k, v in kwargs.items() if k in _KEPT}, cap, array)

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
        """``setJointMotorControlArray`` with only the given arguments (PyBullet's defaults for the rest)."""
        kwargs: dict[str, Sequence[float]] = {}
        if target_positions is not None:
            kwargs["targetPositions"] = target_positions
        if target_velocities is not None:
            kwargs["targetVelocities"] = target_velocities
        if forces is not None:
            kwargs["forces"] = forces
        if position_gains is not None:
            kwargs["positionGains"] = position_gains
        if velocity_gains is not None:
            kwargs["velocityGains"] = velocity_gains
        self.client.setJointMotorControlArray(body, joints, _MODES[mode], **kwargs)
        if mode != "torque":
            for i, joint in enumerate(joints):
                self._keep_motor(body, joint, _MODES[mode], {k: v[i] for k, v in kwargs.items()}, array=True)

    def enable_joint_wrench(self, body: int, joint: int, enabled: bool = True) -> None:
        c = self.client
        c.enableJointForceTorqueSensor(body, joint, 1 if enabled else 0)
        if enabled:  # the child's inertial frame in its link frame: where PyBullet's reaction is given
            position, orientation = c.getDynamicsInfo(body, joint)[3:5]
            rot = np.asarray(c.getMatrixFromQuaternion(orientation), dtype=float).reshape(3, 3)
            self._wrench_shifts[(body, joint)] = (rot, np.asarray(position, dtype=float))
        else:
            self._wrench_shifts.pop((body, joint), None)

    def wrench_frame(self, body: int, joint: int) -> tuple[float, ...]:
        """The child link's frame as ``getLinkState`` kept it from the last step (no forward kinematics rerun)."""
        c = self.client
        return c.getMatrixFromQuaternion(c.getLinkState(body, joint)[5])  # type: ignore[no-any-return]

    def kinematic_chain(self, body: int, link: int) -> list[ChainFrame | ChainJoint]:
        """PyBullet's joint table as a chain: a joint's ``parentFramePos``/``parentFrameOrn`` are given in the parent
        link's *inertial* frame (``getJointInfo`` reports the inverse of the orientation); the child's link frame is
        the joint frame moved by the joint; the next joint frame is given in the child's inertial frame, the link
        frame times its local inertial offset (``getDynamicsInfo`` fields 3, 4). The chain starts at the base's
        inertial frame (``getBasePositionAndOrientation``)."""
        c = self.client
        path = []
        index = link
        while index >= 0:
            path.append(index)
            index = c.getJointInfo(body, index)[16]
        path.reverse()
        steps: list[ChainFrame | ChainJoint] = [ChainFrame(*c.getBasePositionAndOrientation(body))]
        for index in path:
            info = c.getJointInfo(body, index)
            x, y, z, w = info[15]
            steps.append(ChainFrame(info[14], (-x, -y, -z, w)))
            steps.append(ChainJoint(index, info[13], JOINT_TYPES.get(info[2], str(info[2]))))
            if index != path[-1]:
                dyn = c.getDynamicsInfo(body, index)
                steps.append(ChainFrame(dyn[3], dyn[4]))
        return steps

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
        """``calculateInverseKinematics``, the target given in the base's inertial frame as that function expects."""
        c = self.client
        to_base = c.invertTransform(*c.getBasePositionAndOrientation(body))  # world -> the base's inertial frame
        local_pos, local_orn = c.multiplyTransforms(to_base[0], to_base[1], position, orientation)
        return c.calculateInverseKinematics(  # type: ignore[no-any-return]
            body, link, local_pos, local_orn, currentPositions=seed, jointDamping=damping,
            maxNumIterations=iterations, residualThreshold=tolerance)

    def jacobian(self, body: int, link: int, positions: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        zeros = [0.0] * len(positions)
        jl, ja = self.client.calculateJacobian(body, link, [0.0, 0.0, 0.0], list(positions), zeros, zeros)
        return np.asarray(jl), np.asarray(ja)

    # ----------------------------------------------------------------- interface additions: contacts, attachments
    def contacts(
        self, body: int, other: int | None = None, *, link: int | None = None, other_link: int | None = None
    ) -> list[Contact]:
        """``getContactPoints``, each point as a :class:`Contact` (fields 2, 3, 4, 9, 6, 7 of its tuple)."""
        if other is None and link is None and other_link is None:  # the common query (a whole robot), every tick
            points = self.client.getContactPoints(bodyA=body)
        else:
            kwargs: dict[str, int] = {"bodyA": body}
            if other is not None:
                kwargs["bodyB"] = other
            if link is not None:
                kwargs["linkIndexA"] = link
            if other_link is not None:
                kwargs["linkIndexB"] = other_link
            points = self.client.getContactPoints(**kwargs)
        new = tuple.__new__  # builds the named tuple without its Python-level __new__
        return [new(Contact, (cp[2], cp[3], cp[4], cp[9], cp[6], cp[7])) for cp in points]

    def attach(
        self,
        parent: int,
        parent_link: int,
        child: int,
        *,
        position: Sequence[float] | None = None,
        max_force: float | None = None,
    ) -> int:
        """A fixed constraint between the two centre-of-mass frames."""
        c = self.client
        if position is not None:
            constraint = c.createConstraint(parent, parent_link, child, -1, p.JOINT_FIXED, [0, 0, 0],
                                            list(position), [0, 0, 0])
        else:
            if parent_link == -1:
                cup_pos, cup_orn = c.getBasePositionAndOrientation(parent)
            else:
                cup_pos, cup_orn = c.getLinkState(parent, parent_link)[:2]
            obj_pos, obj_orn = c.getBasePositionAndOrientation(child)
            inv_pos, inv_orn = c.invertTransform(cup_pos, cup_orn)
            rel_pos, rel_orn = c.multiplyTransforms(inv_pos, inv_orn, obj_pos, obj_orn)
            constraint = c.createConstraint(parent, parent_link, child, -1, p.JOINT_FIXED, [0, 0, 0],
                                            rel_pos, [0, 0, 0], parentFrameOrientation=rel_orn)
        if max_force is not None:
            c.changeConstraint(constraint, maxForce=max_force)
        return int(constraint)

    def couple_joints(self, body: int, leader: int, follower: int, ratio: float, *, erp: float,
                      max_force: float) -> int:
        """A ``JOINT_GEAR`` constraint (PyBullet's gear ratio has the opposite sign: it is ``-ratio``)."""
        c = self.client
        gear = c.createConstraint(body, leader, body, follower, jointType=p.JOINT_GEAR,
                                  jointAxis=[1, 0, 0], parentFramePosition=[0, 0, 0], childFramePosition=[0, 0, 0])
        c.changeConstraint(gear, gearRatio=-ratio, erp=erp, maxForce=max_force)
        return int(gear)

    def detach(self, attachment: int) -> None:
        self.client.removeConstraint(attachment)

    def joined(self, a: int, b: int) -> bool:
        c = self.client
        for i in range(c.getNumConstraints()):
            info = c.getConstraintInfo(c.getConstraintUniqueId(i))
            if {info[0], info[2]} == {a, b}:
                return True
        return False

    def disable_collisions(self, body: int) -> None:
        c = self.client
        for link in range(-1, c.getNumJoints(body)):
            c.setCollisionFilterGroupMask(body, link, 0, 0)

    def penetration(self, a: int, b: int) -> float:
        """The deepest ``getClosestPoints(a, b, 0)`` distance, negated."""
        return -min((pt[8] for pt in self.client.getClosestPoints(a, b, 0.0)), default=0.0)

    def clashes(self, body: int, joints: Sequence[int], positions: Sequence[float], *,
                carried: Sequence[tuple[int, int, Pose]] = (), skip: Collection[int] = (),
                margin: float = 0.0) -> list[Clash]:
        """The joints reset to the configuration, ``getClosestPoints`` of the arm against every other body, the
        joints reset to their saved positions and velocities (exactly: the run goes on as it would have). A carried
        body is not moved: copies of its base's collision shapes are asked at the pose it would have."""
        c = self.client
        saved = c.getJointStates(body, list(joints)) if len(joints) else []
        movers = [body] + [b for b, _, _ in carried]
        others = [c.getBodyUniqueId(i) for i in range(c.getNumBodies())]
        others = [o for o in others if o not in skip and o not in movers]
        try:
            for joint, q in zip(joints, positions, strict=True):
                c.resetJointState(body, joint, float(q))
            out = [Clash(body, pt[3], other, pt[4], pt[8]) for other in others
                   for pt in c.getClosestPoints(body, other, margin)]
            for b, link, (pos, orn) in carried:
                com = c.multiplyTransforms(*self.pose(body, link), pos, orn)
                for shape, local in self._query_shapes(b):
                    at = c.multiplyTransforms(*com, *local)
                    out += [Clash(b, -1, other, pt[4], pt[8]) for other in others
                            for pt in c.getClosestPoints(-1, other, margin, collisionShapeA=shape,
                                                         collisionShapePositionA=at[0],
                                                         collisionShapeOrientationA=at[1])]
            return out
        finally:
            for joint, state in zip(joints, saved, strict=True):
                c.resetJointState(body, joint, state[0], state[1])

    def _query_shapes(self, body: int) -> list[tuple[int, Pose]]:
        """Collision shapes made once per body, copies of its base's, each with its frame in the base's
        centre-of-mass frame (for :meth:`clashes`)."""
        found = self._shape_copies.get(body)
        if found is None:
            c, found = self.client, []
            for data in c.getCollisionShapeData(body, -1):
                kind, dims, name = data[2], data[3], data[4]
                if kind == c.GEOM_BOX:
                    shape = c.createCollisionShape(kind, halfExtents=[d / 2 for d in dims])
                elif kind == c.GEOM_SPHERE:
                    shape = c.createCollisionShape(kind, radius=dims[0])
                elif kind in (c.GEOM_CYLINDER, c.GEOM_CAPSULE):
                    shape = c.createCollisionShape(kind, radius=dims[1], height=dims[0])
                elif kind == c.GEOM_MESH and name:
                    shape = c.createCollisionShape(kind, fileName=name.decode(), meshScale=dims)
                else:
                    raise UserError(f"cannot check {self._label(body)!r} carried: its collision shape "
                                    f"(type {kind}) cannot be copied")
                found.append((shape, (data[5], data[6])))
            self._shape_copies[body] = found
        return found

    # ----------------------------------------------------------------- interface additions: rays, cameras
    def ray_caster(self, *, skip: Collection[int] = (), see_hidden: bool = True, mask: int = -1,
                   num_threads: int = 1, analytic: bool = True) -> RayCaster:
        """A :class:`~robokit.engines.pybullet.rays.PyBulletRayCaster` (``rayTestBatch``, static mesh boxes in
        numpy); ``see_hidden=False`` leaves group :data:`OWN_BODY_GROUP` out of ``mask``."""
        from robokit.engines.pybullet.rays import PyBulletRayCaster

        if not see_hidden:
            mask &= -1 ^ OWN_BODY_GROUP
        return PyBulletRayCaster(self, skip=skip, mask=mask, num_threads=num_threads, analytic=analytic)

    def hide_from_rays(self, body: int) -> None:
        """Put the body's links in collision group :data:`OWN_BODY_GROUP`; their masks still accept every group
        (Bullet's defaults: a static body ignores other static ones), so collisions are unchanged."""
        c = self.client
        static = c.getDynamicsInfo(body, -1)[0] == 0
        mask = -1 ^ 2 if static else -1
        for link in range(-1, c.getNumJoints(body)):
            c.setCollisionFilterGroupMask(body, link, OWN_BODY_GROUP, mask)

    def view_matrix(self, eye: Sequence[float], target: Sequence[float], up: Sequence[float]) -> tuple[float, ...]:
        return tuple(self.client.computeViewMatrix(list(eye), list(target), list(up)))

    def projection_matrix(self, fov_deg: float, aspect: float, near: float, far: float) -> tuple[float, ...]:
        return tuple(self.client.computeProjectionMatrixFOV(fov=fov_deg, aspect=aspect, nearVal=near, farVal=far))

    def _hardware(self, renderer: str) -> bool:
        # DIRECT mode has no OpenGL context: PyBullet falls back to the TinyRenderer, so "opengl" needs the GUI
        return renderer != "tiny" and self.gui

    def image_sample_offset(self, renderer: str) -> float:
        return 0.5 if self._hardware(renderer) else 0.0  # TinyRenderer samples pixel corners

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
        """``getCameraImage`` (no shadows); the depth buffer turned into metres with ``far * near / (far - (far -
        near) * d)``."""
        c = self.client
        _, _, rgba, depth_buf, seg = c.getCameraImage(
            width, height, viewMatrix=view, projectionMatrix=projection,
            renderer=p.ER_BULLET_HARDWARE_OPENGL if self._hardware(renderer) else p.ER_TINY_RENDERER,
            flags=0 if segmentation else p.ER_NO_SEGMENTATION_MASK, shadow=0, **self.render_options)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        d = np.asarray(depth_buf, dtype=np.float32).reshape(height, width)
        depth = (far * near / (far - (far - near) * d)).astype(np.float32)
        mask = np.asarray(seg, dtype=np.int32).reshape(height, width) if segmentation else None
        return RenderedImage(rgb, depth, mask)

    # ----------------------------------------------------------------- interface additions: pose arithmetic
    def multiply_transforms(self, position_a: Sequence[float], orientation_a: Sequence[float],
                            position_b: Sequence[float], orientation_b: Sequence[float]) -> Pose:
        return self.client.multiplyTransforms(position_a, orientation_a, position_b, orientation_b)  # type: ignore[no-any-return]

    def invert_transform(self, position: Sequence[float], orientation: Sequence[float]) -> Pose:
        return self.client.invertTransform(position, orientation)  # type: ignore[no-any-return]

    def quaternion_from_euler(self, rpy: Sequence[float]) -> Quat:
        return self.client.getQuaternionFromEuler(rpy)  # type: ignore[no-any-return]

    def euler_from_quaternion(self, quaternion: Sequence[float]) -> Vec3:
        return self.client.getEulerFromQuaternion(quaternion)  # type: ignore[no-any-return]

    def matrix_from_quaternion(self, quaternion: Sequence[float]) -> tuple[float, ...]:
        return self.client.getMatrixFromQuaternion(quaternion)  # type: ignore[no-any-return]

    # ----------------------------------------------------------------- interface additions: GUI
    @contextmanager
    def drawing(self) -> Iterator[None]:
        """Rendering paused while lines are drawn: each debug line is a round trip to the GUI thread, which
        otherwise waits for a rendered frame per line."""
        if not self.gui:
            yield
            return
        self.client.configureDebugVisualizer(p.COV_ENABLE_RENDERING, 0)
        try:
            yield
        finally:
            self.client.configureDebugVisualizer(p.COV_ENABLE_RENDERING, 1)

    def key_events(self) -> Mapping[int, int]:
        """``getKeyboardEvents`` (its codes and flags are the interface's)."""
        return self.client.getKeyboardEvents()  # type: ignore[no-any-return]

    # ----------------------------------------------------------------- episodes (robokit.gym)
    def snapshot(self) -> dict[str, Any]:
        """Every registered body's base pose and velocity and joint states, and the joints' motor commands, for
        :meth:`restore` (a cheap reset).

        Only reads: every PyBullet world sorts its overlapping pairs from its build on (see ``__init__``), which
        is what makes contacts after a restore come in a fresh build's order whatever the broadphase's history.
        """
        c, bodies = self.client, {}
        for name, bid in self._bodies.items():
            n = c.getNumJoints(bid)
            joints = [s[:2] for s in c.getJointStates(bid, list(range(n)))] if n else []
            bodies[name] = (c.getBasePositionAndOrientation(bid), c.getBaseVelocity(bid), joints)
        return {"bodies": bodies, "motors": dict(self._motors)}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put every body of a :meth:`snapshot` back, its joints' motors as they were commanded then, and the
        clock to tick 0.

        Contact points cached between bodies are dropped too (every body is moved out of reach of the others
        and collision detection runs once), so an episode after a restore starts exactly as one after a fresh
        build: no warm-started contact impulses carry over. PyBullet cannot read a motor back: the world keeps
        every position and velocity command it sent (``_motors``), and a joint commanded since the snapshot is
        sent its command of then again, or, if it had none, the command equal to PyBullet's own motor of a fresh
        build (a velocity motor to 0 with an impulse of 1 per step, no speed cap).
        """
        c = self.client
        far = 1.0e4
        for k, bid in enumerate(self._bodies.values()):
            c.resetBasePositionAndOrientation(bid, [far * (k + 1), far, far], [0.0, 0.0, 0.0, 1.0])
        c.performCollisionDetection()
        for name, ((pos, orn), (lin, ang), joints) in snapshot["bodies"].items():
            bid = self._bodies[name]
            c.resetBasePositionAndOrientation(bid, pos, orn)
            c.resetBaseVelocity(bid, lin, ang)
            for i, (q, dq) in enumerate(joints):
                c.resetJointState(bid, i, q, dq)
        self._restore_motors(snapshot["motors"])
        self.tick = 0

    def _restore_motors(self, then: dict[tuple[int, int], _Motor]) -> None:
        c = self.client
        for key, now in list(self._motors.items()):
            was = then.get(key)
            if was == now:
                continue
            body, joint = key
            cap = None if was is None else was.cap
            if now.cap != cap:  # the speed cap of then (none: a fresh motor's), set by a command the next one replaces
                c.setJointMotorControl2(body, joint, p.POSITION_CONTROL, maxVelocity=math.inf if cap is None else cap)
            if was is None:
                c.setJointMotorControl2(body, joint, p.VELOCITY_CONTROL, targetVelocity=0.0,
                                        force=_fresh_motor_force(self.time_step))
            elif was.array:  # the same call as then: PyBullet's two calls need not fill in the same defaults
                c.setJointMotorControlArray(body, [joint], was.mode, **{k: [v] for k, v in was.args.items()})
            else:
                c.setJointMotorControl2(body, joint, was.mode, **was.args)
        self._motors = dict(then)

    # ----------------------------------------------------------------- lifetime
    def close(self) -> None:
        """Disconnect the client. Safe to call twice."""
        if self.client is not None:
            try:
                self.client.disconnect()
            except p.error:
                pass
            self.client = None
