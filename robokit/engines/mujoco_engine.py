"""The mujoco engine: :class:`MujocoWorld`, the World on one MuJoCo model built with :class:`mujoco.MjSpec`.

Bodies are added to the spec and compiled when the world is first stepped or looked at (again after a body is
added or removed: the others keep their state). A body id is robokit's, handed out in creation order and stable for
the run; MuJoCo's own ids change at each compile and stay inside this module.

The state after :meth:`MujocoWorld.step` is consistent: ``mj_step2`` integrates, then ``mj_step1`` computes the
positions and velocities of the new state, so poses read between two steps are those of the current state, and
forces and motor commands set then act during the next step.

Units are SI; quaternions are robokit's ``(x, y, z, w)`` (MuJoCo's ``(w, x, y, z)`` stays in here).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robokit.engines import mujoco_attach, mujoco_kin, mujoco_render
from robokit.engines.interface import (
    ChainFrame,
    ChainJoint,
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
)
from robokit.engines.mujoco_gl import mujoco
from robokit.engines.mujoco_links import Motors, critical_damping, joint_table, motor_gains, urdf_joints
from robokit.engines.mujoco_more import MujocoExtras
from robokit.engines.mujoco_render import Cameras
from robokit.engines.mujoco_scene import Scene, add_primitive, load_urdf, mj_quat, mujoco_joints
from robokit.errors import UserError


def _xyzw(q: Any) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


class MujocoWorld(MujocoExtras, World):
    """One MuJoCo model and data, the named bodies in them, the sim clock and the run's random generator.

    Takes the World's keyword arguments; ``gui`` is refused (robokit runs MuJoCo headless).
    """

    engine = "mujoco"

    def __init__(self, *, gui: bool = False, time_step: float = 1.0 / 240.0,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81), solver_iterations: int = 50, seed: int = 0,
                 base_dir: str | Path = ".", engine: str | None = None) -> None:
        if gui:
            raise UserError("world.gui: the mujoco engine runs headless in robokit (--engine pybullet has a GUI)")
        super().__init__(gui=False, time_step=time_step, gravity=gravity, solver_iterations=solver_iterations,
                         seed=seed, base_dir=base_dir, engine=engine)
        self.scene = Scene.new(self.time_step, gravity, solver_iterations)
        self.client: Any = self.scene
        self.model: Any = None
        self.data: Any = None
        self._dirty = True
        self._added = 0
        self._root: dict[int, str] = {}  # robokit id -> MuJoCo root body name
        self._links: dict[int, list[str]] = {}  # robokit id -> link names (index order), URDF names
        self._tables: dict[int, list[JointInfo]] = {}
        self._base_names: dict[int, str] = {}
        self._static: set[str] = set()
        self._bid: dict[int, list[int]] = {}  # robokit id -> MuJoCo body ids of base, link 0, link 1 ...
        self._owner: dict[int, tuple[int, int]] = {}  # MuJoCo body id -> (robokit id, link)
        self._forces: list[tuple[int, np.ndarray, np.ndarray]] = []
        self.motors = Motors()
        self.joins = mujoco_attach.Joins()
        self.cameras = Cameras()
        self._wrenches: dict[tuple[int, int], tuple[tuple[float, ...], tuple[float, ...]]] = {}
        """(body, joint) -> reaction wrench of the last step (child frame) and that frame's rotation."""

    # ----------------------------------------------------------------- stepping and compiling
    def step(self) -> None:
        """Advance physics by one step (forces applied since the last step act during it)."""
        m, d = self.compiled()
        for bid, force, point in self._forces:
            mujoco.mj_applyFT(m, d, force, np.zeros(3), point, bid, d.qfrc_applied)
        mujoco.mj_step2(m, d)
        if self._wrenches:
            self._measure_wrenches()
        if self.motors.torques:
            self.motors.after_step(m, d)
        if self._forces:
            d.qfrc_applied[:] = 0.0
            self._forces.clear()
        mujoco.mj_step1(m, d)
        self.tick += 1

    def compiled(self) -> tuple[Any, Any]:
        """The MuJoCo model and data, compiled first if bodies were added or removed since the last look."""
        if self._dirty:
            self._compile()
        return self.model, self.data

    def _compile(self) -> None:
        spec = self.scene.spec
        for pair in list(spec.pairs):
            spec.delete(pair)
        self.scene.add_restitution_pairs(self._static)
        try:
            if self.model is None:
                self.model = spec.compile()
                self.data = mujoco.MjData(self.model)
            else:
                self.model, self.data = spec.recompile(self.model, self.data)
        except Exception as exc:  # noqa: BLE001 - MuJoCo's compiler raises plain exceptions
            raise UserError(f"MuJoCo could not compile the scene: {str(exc).strip().splitlines()[0]}") from None
        self._dirty = False
        m = self.model
        self._bid = {rid: [m.body(root).id] + [m.body(f"{self._name(rid)}/{link}").id for link in self._links[rid]]
                     for rid, root in self._root.items()}
        self._owner = {bid: (rid, i - 1) for rid, ids in self._bid.items() for i, bid in enumerate(ids)}
        self.scene.apply_damping(m)
        self.motors.reapply(m, self.data, {m.actuator(i).name for i in range(m.nu)})
        mujoco.mj_step1(m, self.data)

    def link_body_name(self, body: str | int, link: int) -> str:
        """MuJoCo's name of a body's base (``-1``) or link."""
        rid = self.body(body)
        return self._root[rid] if link == -1 else f"{self._name(rid)}/{self._links[rid][link]}"

    def changed(self) -> None:
        """The spec changed: compile again at the next look."""
        self._dirty = True

    def mj_body(self, body: str | int, link: int = -1) -> int:
        """MuJoCo's body id of a body's base (``-1``) or link, compiling first if needed."""
        return self._mj(body, link)

    def _name(self, rid: int) -> str:
        return self._names[rid]

    def _mj(self, body: str | int, link: int = -1) -> int:
        rid = self._bodies.get(body) if isinstance(body, str) else None
        if rid is None:
            rid = self.body(body)
        if self._dirty:
            self._compile()
        ids = self._bid[rid]
        if not -1 <= link < len(ids) - 1:
            raise UserError(f"body {self._label(body)!r} has no link {link} (links -1 .. {len(ids) - 2})")
        return ids[link + 1]

    # ----------------------------------------------------------------- building the scene
    def _add(self, name: str, root: str, links: list[str], static: bool) -> int:
        rid = self._register(name, self._added)
        self._added += 1
        self._root[rid], self._links[rid] = root, links
        if static:
            self._static.add(root)
        self._dirty = True
        return rid

    def add_primitive(self, name: str, shape: str, *, size: Sequence[float] = (0.1, 0.1, 0.1), radius: float = 0.05,
                      height: float = 0.1, mass: float = 1.0, position: Sequence[float] = (0.0, 0.0, 0.0),
                      orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
                      rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0), lateral_friction: float | None = None,
                      rolling_friction: float | None = None, spinning_friction: float | None = None,
                      restitution: float | None = None, linear_damping: float | None = None,
                      angular_damping: float | None = None, mesh_collision: bool = False) -> int:
        """A box / sphere / cylinder (see the World). ``mesh_collision`` is a PyBullet speed choice (triangles for
        its ray casts): MuJoCo keeps the box, which its rays hit exactly."""
        if shape not in ("box", "sphere", "cylinder"):
            raise UserError(f"unknown shape {shape!r}; valid: box, cylinder, sphere")
        if mesh_collision and mass != 0:
            raise UserError("a triangle-mesh collision shape needs mass = 0 (static bodies only)")
        if name in self._bodies:
            raise UserError(f"a body named {name!r} already exists")
        add_primitive(self.scene, name, shape, size=size, radius=radius, height=height, mass=mass,
                      position=position, orientation=orientation, rgba=rgba)
        rid = self._add(name, name, [], static=mass <= 0)
        self.set_dynamics(rid, -1, lateral_friction=lateral_friction, rolling_friction=rolling_friction,
                          spinning_friction=spinning_friction, restitution=restitution,
                          linear_damping=linear_damping, angular_damping=angular_damping)
        return rid

    def load_urdf(self, name: str, urdf: str, *, position: Sequence[float] = (0.0, 0.0, 0.0),
                  orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0), fixed_base: bool = False, scale: float = 1.0,
                  self_collision: bool = False) -> int:
        """Load a URDF: its links become bodies ``NAME/LINK``; joints keep the URDF's names and limits."""
        if name in self._bodies:
            raise UserError(f"a body named {name!r} already exists")
        path = Path(self.resolve_urdf(urdf))
        root, links = load_urdf(self.scene, name, path, position=position, orientation=orientation,
                                fixed_base=fixed_base, self_collision=self_collision, scale=scale)
        rid = self._add(name, root.name, links, static=not root.joints)
        self._tables[rid] = joint_table(links, urdf_joints(path), mujoco_joints(name, links, self.scene.spec))
        self._base_names[rid] = root.name[len(name) + 1:]
        return rid

    def set_dynamics(self, body: int | str, link: int = -1, **params: float | None) -> None:
        """Contact and damping parameters of a body's base or link (see :mod:`robokit.engines.mujoco_scene`)."""
        values = {k: float(v) for k, v in params.items() if v is not None}
        if not values:
            return
        rid = self.body(body)
        target = self._root[rid] if link == -1 else f"{self._name(rid)}/{self._links[rid][link]}"
        mass = values.pop("mass", None)
        if mass is not None and not (link == -1 and self._root[rid] in self._static):
            self.scene.set_mass(self.scene.spec.body(target), mass)
        values.pop("friction_anchor", None)  # PyBullet's; MuJoCo's soft contacts have no anchor to keep
        joint_damping = values.pop("joint_damping", None)
        if joint_damping is not None:
            for joint in self.scene.spec.body(target).joints:
                damping = list(joint.damping)
                damping[0] = joint_damping
                joint.damping = damping
        linear, angular = values.pop("linear_damping", None), values.pop("angular_damping", None)
        if (linear is not None or angular is not None) and link == -1 and self._root[rid] not in self._static:
            self.scene.set_damping(target, linear, angular)
        self.scene.set_contact(self.scene.spec.body(target), values)
        self._dirty = True

    def remove_body(self, name: str) -> None:
        """Remove a body (the scene is recompiled; the other bodies keep their state)."""
        rid = self.body(name)
        self.compiled()
        for attachment in [a for a, (p, c, _) in self.joins.held.items() if rid in (p, c)]:
            self.detach(attachment)
        self.mounts = {c: p for c, p in self.mounts.items() if rid not in (c, p)}
        root = self._root.pop(rid)
        body = self.scene.spec.body(root)
        for geom in self.scene.geoms_of(body):
            self.scene.contacts.pop(geom.name, None)
        for actuator in list(self.scene.spec.actuators):
            if actuator.name.startswith(f"{name}/"):
                self.scene.spec.delete(actuator)
        self.scene.spec.delete(body)
        self._static.discard(root)
        self.scene.damping.pop(root, None)
        self._links.pop(rid)
        self._tables.pop(rid, None)
        self._unregister(name)
        self._dirty = True

    # ----------------------------------------------------------------- bodies, links, joints (read)
    def joints(self, body: str | int) -> list[JointInfo]:
        """Every joint of a body in index order (a primitive has none)."""
        return self._tables.get(self.body(body), [])

    def base_link_name(self, body: str | int) -> str:
        """The base link's URDF name (a primitive's is ``link0``, as on PyBullet)."""
        return self._base_names.get(self.body(body), "link0")

    def joint_parent(self, body: str | int, joint: int) -> int:
        """Link index that joint ``joint`` hangs from (``-1`` = the base)."""
        child = self._mj(body, joint)
        return self._owner[int(self.model.body_parentid[child])][1]

    def mass(self, body: str | int, link: int = -1) -> float:
        """Mass of a body's base or link, kg (0 for a static body; a moving base with no mass of its own, as the
        husky's ``base_footprint``, reports the mass of the whole body, so that it never reads as static)."""
        bid = self._mj(body, link)
        if link == -1 and self._root[self.body(body)] in self._static:
            return 0.0
        mass = float(self.model.body_mass[bid])
        if link == -1 and mass == 0.0:  # a URDF base without inertia that still moves: what it carries (not static)
            return float(self.model.body_subtreemass[bid])
        return mass

    def dynamics(self, body: str | int, link: int = -1) -> dict[str, float]:
        """Mass and contact parameters of a base or link now (its first geom's friction; restitution as set)."""
        bid = self._mj(body, link)
        m = self.model
        out = {"mass": self.mass(body, link), "lateral_friction": 0.0, "rolling_friction": 0.0,
               "spinning_friction": 0.0, "restitution": 0.0}
        if m.body_geomnum[bid]:
            g = int(m.body_geomadr[bid])
            slide, spin, roll = (float(v) for v in m.geom_friction[g])
            out.update(lateral_friction=slide, spinning_friction=spin, rolling_friction=roll,
                       restitution=self.scene.restitution(m.geom(g).name))
        return out

    def set_visual_rgba(self, body: str | int, rgba: Sequence[float], link: int = -1) -> None:
        """Recolour a base or link's geoms (what cameras see)."""
        bid = self._mj(body, link)
        for geom in self.scene.spec.body(self.model.body(bid).name).geoms:
            geom.rgba = list(rgba)
        m = self.model
        m.geom_rgba[m.body_geomadr[bid]:m.body_geomadr[bid] + m.body_geomnum[bid]] = list(rgba)

    def penetration(self, a: int, b: int) -> float:
        """Deepest interpenetration of two bodies now (m; 0 when apart), from MuJoCo's contacts of this state."""
        m, d = self.compiled()
        ra, rb, deepest = self.body(a), self.body(b), 0.0
        for i in range(d.ncon):
            con = d.contact[i]
            owners = {self._owner.get(int(m.geom_bodyid[g]), (-1, -1))[0] for g in con.geom}
            if owners == {ra, rb}:
                deepest = max(deepest, -float(con.dist))
        return deepest

    def visual_rgba(self, body: str | int) -> tuple[float, float, float, float] | None:
        """Colour of the body's first geom, 0..1."""
        bid = self._mj(body)
        m = self.model
        if m.body_geomnum[bid] == 0:
            return None
        r, g, b, a = (float(v) for v in m.geom_rgba[m.body_geomadr[bid]])
        return (r, g, b, a)

    # ----------------------------------------------------------------- poses and motion
    def pose(self, body: str | int, link: int = -1) -> Pose:
        """Link-frame pose: position (m, world) and ``(x, y, z, w)``."""
        bid = self._mj(body, link)
        return _vec(self.data.xpos[bid]), _xyzw(self.data.xquat[bid])

    def com_pose(self, body: str | int, link: int = -1) -> Pose:
        """Centre-of-mass (inertial) frame pose, world frame."""
        bid = self._mj(body, link)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, self.data.ximat[bid])
        return _vec(self.data.xipos[bid]), _xyzw(quat)

    def link_offset(self, body: str | int) -> Pose | None:
        """The base's link frame seen from its centre of mass, or None when they coincide."""
        bid = self._mj(body)
        ipos, iquat = self.model.body_ipos[bid], self.model.body_iquat[bid]
        if np.abs(ipos).max() < 1e-12 and abs(abs(iquat[0]) - 1.0) < 1e-12:
            return None
        from robokit.engines.mujoco_math import invert

        return invert(_vec(ipos), _xyzw(iquat))

    def velocity(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Linear velocity of the base's centre of mass (m/s) and angular velocity (rad/s), world frame."""
        return self.link_velocity(body, -1)

    def link_velocity(self, body: str | int, link: int) -> tuple[Vec3, Vec3]:
        """Linear (of the centre of mass, m/s) and angular (rad/s) velocity of a link, world frame."""
        bid = self._mj(body, link)
        out = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_BODY, bid, out, 0)
        return _vec(out[3:]), _vec(out[:3])

    def body_states(self, bodies: Sequence[int]) -> list[tuple[Vec3, Quat, Vec3, Vec3]]:
        """Pose and velocity of each body's base, in one call."""
        out = []
        for body in bodies:
            pos, orn = self.pose(body)
            lin, ang = self.velocity(body)
            out.append((pos, orn, lin, ang))
        return out

    def set_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None = None) -> None:
        """Teleport a body's base (velocity zeroed). For set-up and tests, not for control. A static body becomes a
        MuJoCo mocap body the first time it is moved (recompiled once): still static to the physics, now movable."""
        bid = self._mj(body)
        m, d = self.model, self.data
        if m.body_jntnum[bid] == 0:
            self._move_static(body, position, orientation)
            return
        if m.jnt_type[m.body_jntadr[bid]] != mujoco.mjtJoint.mjJNT_FREE:
            raise UserError(f"body {self._label(body)!r} is jointed to the world: the mujoco engine cannot move it")
        joint = m.body_jntadr[bid]
        qadr, dadr = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
        d.qpos[qadr:qadr + 3] = list(position)
        if orientation is not None:
            d.qpos[qadr + 3:qadr + 7] = mj_quat(orientation)
        d.qvel[dadr:dadr + 6] = 0.0
        mujoco.mj_step1(m, d)

    def _move_static(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None) -> None:
        spec_body = self.scene.spec.body(self._root[self.body(body)])
        if not spec_body.mocap:
            spec_body.mocap = True
            self._dirty = True
        m, d = self.compiled()
        mocap = int(m.body_mocapid[self._mj(body)])
        d.mocap_pos[mocap] = list(position)
        if orientation is not None:
            d.mocap_quat[mocap] = mj_quat(orientation)
        mujoco.mj_step1(m, d)

    def set_com_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float]) -> None:
        """Teleport a free body so that its centre-of-mass frame is at ``position`` / ``orientation``; velocity kept."""
        from robokit.engines.mujoco_math import multiply

        offset = self.link_offset(body)
        pos, orn = (position, orientation) if offset is None else multiply(position, orientation, *offset)
        _, d = self.compiled()
        qvel = d.qvel.copy()
        self.set_pose(body, pos, orn)
        d.qvel[:] = qvel
        mujoco.mj_step1(self.model, d)

    def aabb(self, body: str | int, link: int = -1) -> tuple[Vec3, Vec3]:
        """Axis-aligned box ``(min, max)`` around one link's geoms (m, world frame)."""
        return self._box([self._mj(body, link)])

    def body_aabb(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Axis-aligned box around every geom of a body and its links (m, world frame)."""
        self._mj(body)
        return self._box(self._bid[self.body(body)])

    def _box(self, bodies: list[int]) -> tuple[Vec3, Vec3]:
        m, d = self.model, self.data
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for bid in bodies:
            for g in range(m.body_geomadr[bid], m.body_geomadr[bid] + m.body_geomnum[bid]):
                rot = d.geom_xmat[g].reshape(3, 3)
                mid = d.geom_xpos[g] + rot @ m.geom_aabb[g, :3]
                ext = np.abs(rot) @ m.geom_aabb[g, 3:]
                lo, hi = np.minimum(lo, mid - ext), np.maximum(hi, mid + ext)
        if not np.isfinite(lo).all():
            lo = hi = d.xpos[bodies[0]]
        return _vec(lo), _vec(hi)

    def apply_force(self, body: str | int, force: Sequence[float], *, position: Sequence[float] | None = None,
                    link: int = -1) -> None:
        """Apply a force (N, world frame) at a world point (default: the link's centre of mass) in the next step."""
        bid = self._mj(body, link)
        at = np.asarray(position if position is not None else self.data.xipos[bid], dtype=float)
        self._forces.append((bid, np.asarray(force, dtype=float), at))

    # ----------------------------------------------------------------- joints: state and motors
    def _joint(self, body: int | str, joint: int) -> tuple[int, int, int]:
        """MuJoCo joint id, qpos address and dof address of a movable joint."""
        bid = self._mj(body, joint)
        m = self.model
        if m.body_jntnum[bid] == 0:
            raise UserError(f"joint {joint} of {self._label(body)!r} is fixed")
        jid = int(m.body_jntadr[bid])
        return jid, int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid])

    def joint_states(self, body: int, joints: Sequence[int]) -> Sequence[JointState]:
        """Position, velocity, reaction wrench (zeros unless :meth:`enable_joint_wrench`) and last motor force of
        each joint; a fixed joint reads position and velocity 0."""
        out = []
        m, d = self.compiled()
        for j in joints:
            reaction = self._wrenches.get((self.body(body), j), ((0.0,) * 6, ()))[0]
            bid = self._mj(body, j)
            if m.body_jntnum[bid] == 0:
                out.append(JointState(0.0, 0.0, reaction, 0.0))  # type: ignore[arg-type]
                continue
            _, qadr, dadr = self._joint(body, j)
            torque = float(d.qfrc_actuator[dadr])
            out.append(JointState(float(d.qpos[qadr]), float(d.qvel[dadr]), reaction, torque))  # type: ignore[arg-type]
        return out

    def enable_joint_wrench(self, body: int, joint: int, enabled: bool = True) -> None:
        """Measure (or stop measuring) a joint's reaction wrench at every step."""
        key = (self.body(body), joint)
        if enabled:
            self._mj(body, joint)
            self._wrenches.setdefault(key, ((0.0,) * 6, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)))
        else:
            self._wrenches.pop(key, None)

    def wrench_frame(self, body: int, joint: int) -> tuple[float, ...]:
        """Rotation (world from child link frame) the joint's reaction was given in, as of the last step."""
        return self._wrenches.get((self.body(body), joint), ((), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)))[1]

    def _measure_wrenches(self) -> None:
        m, d = self.model, self.data
        mujoco.mj_rnePostConstraint(m, d)
        for (rid, joint) in self._wrenches:
            self._wrenches[(rid, joint)] = mujoco_kin.joint_wrench(m, d, self._mj(rid, joint))

    def reset_joint(self, body: int, joint: int, position: float, velocity: float | None = None) -> None:
        """Set a joint's position and velocity at once (set-up and resets)."""
        _, qadr, dadr = self._joint(body, joint)
        self.data.qpos[qadr] = position
        self.data.qvel[dadr] = velocity or 0.0
        mujoco.mj_step1(self.model, self.data)

    def set_joint_motor(self, body: int, joint: int, mode: MotorMode, *, target_position: float | None = None,
                        target_velocity: float | None = None, force: float | None = None,
                        max_velocity: float | None = None, position_gain: float | None = None) -> None:
        """Drive one joint with its MuJoCo motor; gains come from MuJoCo's model of the joint
        (:func:`~robokit.engines.mujoco_links.motor_gains`), not from PyBullet's."""
        jid, _, dadr = self._joint(body, joint)
        m, d = self.model, self.data
        info = self.joints(body)[joint]
        limit = abs(float(force)) if force is not None else info.max_force
        inertia = float(m.dof_M0[dadr])
        kv, kp = motor_gains(limit, inertia, self.time_step)
        if mode == "torque":
            setting = (1.0, 0.0, 0.0, limit, float(force or 0.0))
        elif mode == "velocity":
            setting = (kv, 0.0, -kv, limit if force is not None or limit > 0 else 0.0, float(target_velocity or 0.0))
        else:
            setting = (kp, -kp, -critical_damping(kp, inertia), limit, float(target_position or 0.0))
        if force is not None and limit == 0.0:  # force 0: the motor is off (a passive joint)
            setting = (0.0, 0.0, 0.0, 0.0, 0.0)
        self.motors.set(m, d, f"{m.joint(jid).name}/motor", setting, torque=mode == "torque")

    def set_joint_motors(self, body: int, joints: Sequence[int], mode: MotorMode, *,
                         target_positions: Sequence[float] | None = None,
                         target_velocities: Sequence[float] | None = None, forces: Sequence[float] | None = None,
                         position_gains: Sequence[float] | None = None,
                         velocity_gains: Sequence[float] | None = None) -> None:
        """:meth:`set_joint_motor` for many joints."""
        for i, joint in enumerate(joints):
            self.set_joint_motor(body, joint, mode,
                                 target_position=None if target_positions is None else target_positions[i],
                                 target_velocity=None if target_velocities is None else target_velocities[i],
                                 force=None if forces is None else forces[i])

    # ----------------------------------------------------------------- rays
    def owners(self) -> dict[int, tuple[int, int]]:
        """MuJoCo body id -> (robokit body id, link), for the scene as compiled now."""
        self.compiled()
        return self._owner

    def ray_caster(self, *, skip: Collection[int] = (), see_hidden: bool = True, mask: int = -1,
                   num_threads: int = 1, analytic: bool = True) -> RayCaster:
        """A caster on MuJoCo's ``mj_multiRay`` / ``mj_ray`` (``mask``, ``num_threads``, ``analytic`` do not apply)."""
        from robokit.engines.mujoco_rays import MujocoRayCaster

        return MujocoRayCaster(self, skip, see_hidden)

    def hide_from_rays(self, body: int) -> None:
        """Put the body's geoms in the geom group rays of ``see_hidden=False`` casters leave out."""
        from robokit.engines.mujoco_rays import HIDDEN_GROUP

        for geom in self.scene.geoms_of(self.scene.spec.body(self._root[self.body(body)])):
            geom.group = HIDDEN_GROUP
        self._dirty = True

    # ----------------------------------------------------------------- attachments
    def attach(self, parent: int, parent_link: int, child: int, *, position: Sequence[float] | None = None,
               max_force: float | None = None) -> int:
        """A weld (see :mod:`robokit.engines.mujoco_attach`)."""
        return mujoco_attach.attach(self, parent, parent_link, child, position=position, max_force=max_force)

    def mount(self, child: str, parent: str, link: int, *, position: Sequence[float] = (0.0, 0.0, 0.0),
              orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0), max_force: float = 10_000.0) -> int:
        """A tool on a flange: a weld, the two bodies out of each other's contacts (MuJoCo's stiffness)."""
        return mujoco_attach.mount(self, child, parent, link, position, orientation)

    def couple_joints(self, body: int, leader: int, follower: int, ratio: float, *, erp: float,
                      max_force: float) -> int:
        """A joint equality (see :mod:`robokit.engines.mujoco_attach`)."""
        return mujoco_attach.couple_joints(self, body, leader, follower, ratio, erp=erp, max_force=max_force)

    def detach(self, attachment: int) -> None:
        """Remove an attachment."""
        mujoco_attach.detach(self, attachment)

    def joined(self, a: int, b: int) -> bool:
        """True if an attachment joins ``a`` and ``b`` directly."""
        return mujoco_attach.joined(self, a, b)

    def disable_collisions(self, body: int) -> None:
        """Take a body's base out of contact."""
        mujoco_attach.disable_collisions(self, body)

    # ----------------------------------------------------------------- kinematics
    def kinematic_chain(self, body: int, link: int) -> list[ChainFrame | ChainJoint]:
        """The frames from the world to a link (see :mod:`robokit.engines.mujoco_kin`)."""
        return mujoco_kin.kinematic_chain(self, body, link)

    def jacobian(self, body: int, link: int, positions: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo's Jacobian of a link's centre of mass (see :mod:`robokit.engines.mujoco_kin`)."""
        return mujoco_kin.jacobian(self, body, link, positions)

    # ----------------------------------------------------------------- cameras
    def render(self, width: int, height: int, view: Sequence[float], projection: Sequence[float], *, near: float,
               far: float, segmentation: bool = True, renderer: str = "tiny") -> RenderedImage:
        """One image from MuJoCo's OpenGL renderer (``renderer`` does not apply: there is one)."""
        return mujoco_render.render(self, width, height, view, projection, near=near, far=far,
                                    segmentation=segmentation)

    # ----------------------------------------------------------------- contacts
    def contacts(self, body: int, other: int | None = None, *, link: int | None = None,
                 other_link: int | None = None) -> list[Contact]:
        """Contact points of ``body`` after the last step; the point is MuJoCo's (midway between the surfaces)."""
        m, d = self.compiled()
        rid = self.body(body)
        out = []
        wrench = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            own = [self._owner.get(int(m.geom_bodyid[g]), (-1, -1)) for g in con.geom]
            for side in (0, 1):
                (a, la), (b, lb) = own[side], own[1 - side]
                if a != rid or (link is not None and la != link) or (other is not None and b != other):
                    continue
                if other_link is not None and lb != other_link:
                    continue
                mujoco.mj_contactForce(m, d, i, wrench)
                normal = con.frame[:3] * (-1.0 if side == 0 else 1.0)  # MuJoCo's points from geom 1 to geom 2
                out.append(Contact(b, la, lb, float(wrench[0]), _vec(con.pos), _vec(normal)))
        return out

    # ----------------------------------------------------------------- episodes, lifetime
    def snapshot(self) -> dict[str, Any]:
        """The whole state (positions, velocities, motor commands)."""
        _, d = self.compiled()
        return {"qpos": d.qpos.copy(), "qvel": d.qvel.copy(), "ctrl": d.ctrl.copy()}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put a :meth:`snapshot` back exactly, warm starts cleared, and the clock to tick 0."""
        m, d = self.compiled()
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:], d.ctrl[:] = snapshot["qpos"], snapshot["qvel"], snapshot["ctrl"]
        mujoco.mj_step1(m, d)
        self.tick = 0

    def close(self) -> None:
        """Close the renderers, drop the model and data. Safe to call twice."""
        self.cameras.close()
        self.model = self.data = self.client = None
