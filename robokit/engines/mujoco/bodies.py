"""The mujoco engine's bodies: :class:`MujocoBodies`, the half of the World on MuJoCo that builds the scene with
:class:`mujoco.MjSpec`, compiles it, and answers where bodies and links are (the devices' half is
:class:`~robokit.engines.mujoco.world.MujocoWorld`).

Bodies are added to the spec and compiled when the world is first stepped or looked at (again after a body is
added or removed: the others keep their state). A body id is robokit's, handed out in creation order and stable for
the run; MuJoCo's own ids change at each compile and stay inside the engine.

Units are SI; quaternions are robokit's ``(x, y, z, w)`` (MuJoCo's ``(w, x, y, z)`` stays in here).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from robokit.engines.interface import JointInfo, Pose, Quat, Vec3, World, display_problem
from robokit.engines.mujoco.extras import MujocoExtras
from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.links import joint_table, urdf_joints
from robokit.engines.mujoco.scene import Scene, add_primitive, load_urdf, mj_quat, mujoco_joints
from robokit.engines.mujoco.window import Window
from robokit.errors import UserError


def _xyzw(q: Any) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


class MujocoHandle:
    """``world.client`` on the mujoco engine: MuJoCo's own ``model``, ``data`` and ``spec`` (for engine-aware
    tools). Anything else is a PyBullet call a plugin reached for: the error says so in one line."""

    def __init__(self, world: MujocoBodies) -> None:
        self._world = world

    @property
    def model(self) -> Any:
        return self._world.compiled()[0]

    @property
    def data(self) -> Any:
        return self._world.compiled()[1]

    @property
    def spec(self) -> Any:
        return self._world.scene.spec

    def __getattr__(self, name: str) -> Any:
        raise AttributeError(f"world.client.{name} is a PyBullet call; on the mujoco engine world.client is MuJoCo's "
                             f"(model, data, spec): use the World's methods (docs/plugins.md)")


class MujocoBodies(MujocoExtras, World):
    """One MuJoCo model and data and the named bodies in them (see the module's docstring)."""

    def __init__(self, *, gui: bool = False, time_step: float = 1.0 / 240.0,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81), solver_iterations: int = 50, seed: int = 0,
                 base_dir: str | Path = ".", engine: str | None = None) -> None:
        problem = self.window_problem() if gui else None
        if problem is not None:
            raise UserError(f"MuJoCo's viewer window cannot open: {problem}")
        super().__init__(gui=gui, time_step=time_step, gravity=gravity, solver_iterations=solver_iterations,
                         seed=seed, base_dir=base_dir, engine=engine)
        self.window: Window | None = Window() if gui else None
        """MuJoCo's passive viewer (``gui``), shown from the first compile on."""
        self.scene = Scene.new(self.time_step, gravity, solver_iterations)
        self.client: Any = MujocoHandle(self)
        self._model: Any = None
        self._data: Any = None
        self._unsettled = False
        """The positions stage (``mj_step1``) of the last step, or of positions written since, is still to run: see
        :meth:`_settle`."""
        self._stepped = False
        """The data holds the contacts a step solved, not yet kept (:meth:`_settle` keeps them first)."""
        self._dirty = True
        self._added = 0
        self._root: dict[int, str] = {}  # robokit id -> MuJoCo root body name
        self._links: dict[int, list[str]] = {}  # robokit id -> link names (index order), URDF names
        self._tables: dict[int, list[JointInfo]] = {}
        self._base_names: dict[int, str] = {}
        self._static: set[str] = set()
        self._bid: dict[int, list[int]] = {}  # robokit id -> MuJoCo body ids of base, link 0, link 1 ...
        self._owner: dict[int, tuple[int, int]] = {}  # MuJoCo body id -> (robokit id, link)
        self._inertial = np.zeros((0, 4))  # per MuJoCo body: its centre-of-mass frame in its body frame (w, x, y, z)

    # ----------------------------------------------------------------- stepping and compiling
    @property
    def model(self) -> Any:
        """MuJoCo's model, with the state brought up to date first (:meth:`_settle`)."""
        if self._unsettled:
            self._settle()
        return self._model

    @property
    def data(self) -> Any:
        """MuJoCo's data, with the state brought up to date first (:meth:`_settle`)."""
        if self._unsettled:
            self._settle()
        return self._data

    def _settle(self) -> None:
        """Run the positions stage (``mj_step1``) of the last step or of written positions, left until something
        looks at the model or data: a step that follows with nothing read in between runs it itself, on the same
        state."""
        self._unsettled = self._stepped = False
        mujoco.mj_step1(self._model, self._data)

    def _for_writing(self) -> tuple[Any, Any]:
        """The model and data to write positions into: compiled, a step's solved contacts kept (:meth:`_settle`),
        and the positions stage of earlier writes left to run once after these."""
        if self._dirty:
            self._compile()
        if self._stepped:
            self._settle()
        return self._model, self._data

    def _positions_written(self) -> None:
        """Joint positions or velocities were written: the positions stage runs when something next looks."""
        self._unsettled = True

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
        holds = self.scene.grips.holds(self.model) if self.model is not None else []
        try:
            if self.model is None:
                self._model = spec.compile()
                self._data = mujoco.MjData(self._model)
            else:
                self._model, self._data = spec.recompile(self.model, self.data)
        except Exception as exc:  # noqa: BLE001 - MuJoCo's compiler raises plain exceptions
            raise UserError(f"MuJoCo could not compile the scene: {str(exc).strip().splitlines()[0]}") from None
        self._dirty = False
        m = self.model
        self._bid = {rid: [m.body(root).id] + [m.body(f"{self._name(rid)}/{link}").id for link in self._links[rid]]
                     for rid, root in self._root.items()}
        self._owner = {bid: (rid, i - 1) for rid, ids in self._bid.items() for i, bid in enumerate(ids)}
        self._inertial = self._inertial_frames(m)
        self.scene.apply_damping(m)
        self.scene.grips.compiled(m)
        self.scene.grips.hold_again(m, self.data, holds)  # what the fingers held, they hold in the new model
        self._after_compile(m)
        if holds:  # mid-run, something held: the contacts and their forces now, as a step would have left them
            mujoco.mj_forward(m, self.data)
            self._keep_contacts(m, self.data)
        else:
            mujoco.mj_step1(m, self.data)
        if self.window is not None:
            self.window.show(m, self.data)

    @classmethod
    def window_problem(cls) -> str | None:
        """MuJoCo's viewer needs a display as PyBullet's window does (see
        :func:`~robokit.engines.interface.display_problem`)."""
        return display_problem()

    def _inertial_frames(self, m: Any) -> np.ndarray:
        """Per MuJoCo body, the orientation ``(w, x, y, z)`` of its centre-of-mass frame in its body frame as the
        model file defines it (a URDF's ``<inertial><origin rpy>``, as PyBullet takes it). MuJoCo's compiler keeps
        only the principal axes of the inertia (``body_iquat``), whose order and signs follow the eigenvalues: a
        URDF link with a diagonal inertia in its link frame could come out turned by a quarter or a half turn."""
        frames = np.array(m.body_iquat, dtype=float)
        spec = self.scene.spec
        for bid in range(1, m.nbody):
            given = spec.body(m.body(bid).name)
            if given is not None and not np.isnan(given.fullinertia[0]):
                q = np.asarray(given.iquat, dtype=float)
                frames[bid] = q / np.linalg.norm(q)
        return frames

    def _after_compile(self, model: Any) -> None:
        """What a subclass puts back into a freshly compiled model (nothing here)."""

    def _keep_contacts(self, model: Any, data: Any) -> None:
        """Keep the solved contacts of ``data`` for the contact queries of a subclass (none here)."""

    def owners(self) -> dict[int, tuple[int, int]]:
        """MuJoCo body id -> (robokit body id, link), for the scene as compiled now."""
        self.compiled()
        return self._owner

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

    def load_model(self, name: str, path: str, kind: str, *, position: Sequence[float] = (0.0, 0.0, 0.0),
                   orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0), fixed_base: bool = False,
                   scale: float = 1.0) -> list[int]:
        """Load an MJCF file (see :mod:`robokit.engines.mujoco.mjcf`); SDF is PyBullet's only."""
        if kind != "mjcf":
            raise UserError(f"{kind.upper()} {path!r}: the mujoco engine loads URDF and MJCF files, not {kind.upper()}")
        from robokit.engines.mujoco.mjcf import load_mjcf

        resolved = Path(self.resolve_urdf(path))
        names = [name] + [f"{name}_{k}" for k in range(1, 64)]
        taken = [n for n in names if n in self._bodies]
        if name in taken:
            raise UserError(f"a body named {name!r} already exists")
        ids = []
        for k, (root, links) in enumerate(load_mjcf(self.scene, names, resolved, position=position,
                                                    orientation=orientation, fixed_base=fixed_base, scale=scale)):
            rid = self._add(names[k], root.name, links, static=not root.joints)
            self._tables[rid] = joint_table(links, {}, mujoco_joints(names[k], links, self.scene.spec))
            self._base_names[rid] = root.name[len(names[k]) + 1:]
            ids.append(rid)
        return ids

    def set_dynamics(self, body: int | str, link: int = -1, **params: float | None) -> None:
        """Contact and damping parameters of a body's base or link (see :mod:`robokit.engines.mujoco.scene`)."""
        values = {k: float(v) for k, v in params.items() if v is not None}
        if not values:
            return
        rid = self.body(body)
        target = self._root[rid] if link == -1 else f"{self._name(rid)}/{self._links[rid][link]}"
        mass = values.pop("mass", None)
        if mass is not None and not (link == -1 and self._root[rid] in self._static):
            self.scene.set_mass(self.scene.spec.body(target), mass)
        if values.pop("friction_anchor", 0.0):  # a gripper's finger: the stiffest contact MuJoCo allows
            self.scene.set_grip(self.scene.spec.body(target))
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
        """Centre-of-mass (inertial) frame pose, world frame: the model file's inertial frame (see
        :meth:`_inertial_frames`), not MuJoCo's principal axes."""
        bid = self._mj(body, link)
        quat = np.zeros(4)
        mujoco.mju_mulQuat(quat, self.data.xquat[bid], self._inertial[bid])
        return _vec(self.data.xipos[bid]), _xyzw(quat)

    def link_offset(self, body: str | int) -> Pose | None:
        """The base's link frame seen from its centre of mass, or None when they coincide."""
        bid = self._mj(body)
        ipos, iquat = self.model.body_ipos[bid], self._inertial[bid]
        if np.abs(ipos).max() < 1e-12 and abs(abs(iquat[0]) - 1.0) < 1e-12:
            return None
        from robokit.engines.mujoco.spatial import invert

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
        m, d = self._for_writing()
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
        self._positions_written()

    def _move_static(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None) -> None:
        spec_body = self.scene.spec.body(self._root[self.body(body)])
        if not spec_body.mocap:
            spec_body.mocap = True
            self._dirty = True
        m, d = self._for_writing()
        mocap = int(m.body_mocapid[self._mj(body)])
        d.mocap_pos[mocap] = list(position)
        if orientation is not None:
            d.mocap_quat[mocap] = mj_quat(orientation)
        self._positions_written()

    def set_com_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float]) -> None:
        """Teleport a free body so that its centre-of-mass frame is at ``position`` / ``orientation``; velocity kept."""
        from robokit.engines.mujoco.spatial import multiply

        offset = self.link_offset(body)
        pos, orn = (position, orientation) if offset is None else multiply(position, orientation, *offset)
        _, d = self._for_writing()
        qvel = d.qvel.copy()
        self.set_pose(body, pos, orn)
        self._for_writing()[1].qvel[:] = qvel
        self._positions_written()

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
