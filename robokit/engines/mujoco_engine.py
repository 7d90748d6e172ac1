"""The World on MuJoCo: bodies built with :class:`mujoco.MjSpec`, compiled when first stepped or looked at.

Units are SI; positions are world frame ``(x, y, z)``; quaternions are robokit's ``(x, y, z, w)`` (MuJoCo's own
``(w, x, y, z)`` never leaves this package). A body's id is robokit's, given in creation order and stable for the
run; MuJoCo's body ids change when the scene is recompiled (a body added or removed) and stay in here.

The state after :meth:`MujocoWorld.step` is consistent: MuJoCo's ``mj_step2`` integrates, then ``mj_step1``
computes positions and velocities of the new state, so poses read between two steps are those of the current
state and forces applied then act in the next step.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from robokit.core.world import World as _PyBulletWorld
from robokit.engines.mujoco_scene import Scene, add_primitive, load_urdf, mj_quat
from robokit.errors import LookupNameError, UserError

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def _xyzw(q: Any) -> Quat:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _vec(v: Any) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


class MujocoWorld:
    """One MuJoCo model and data, the named bodies in them, the sim clock and the run's random generator.

    Args mirror the PyBullet World's: ``time_step`` (s), ``gravity`` (m/s²), ``solver_iterations``, ``seed``,
    ``base_dir`` (where relative URDF paths are looked up). ``gui`` is refused: MuJoCo runs headless here.
    """

    engine = "mujoco"

    def __init__(self, *, gui: bool = False, time_step: float = 1.0 / 240.0,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81), solver_iterations: int = 50, seed: int = 0,
                 base_dir: str | Path = ".") -> None:
        if gui:
            raise UserError("world.gui: the mujoco engine runs headless in robokit (use --engine pybullet for a GUI)")
        self.gui = False
        self.time_step = float(time_step)
        self.seed = int(seed)
        self.base_dir = Path(base_dir)
        self.tick = 0
        self._rng: np.random.Generator | None = None
        self.scene = Scene.new(self.time_step, gravity, solver_iterations)
        self.model: Any = None
        self.data: Any = None
        self._dirty = True
        self._bodies: dict[str, int] = {}
        self._names: dict[int, str] = {}
        self._mj_name: dict[int, str] = {}  # robokit id -> MuJoCo root body name
        self._static: set[str] = set()
        self._mj_id: dict[int, int] = {}  # robokit id -> MuJoCo body id (rebuilt at each compile)
        self._forces: list[tuple[int, np.ndarray, np.ndarray]] = []
        self.mounts: dict[int, int] = {}
        self.removals = 0
        self.render_options: dict[str, Any] = {}

    sample_positions = _PyBulletWorld.sample_positions  # engine-neutral: draws from self.rng only

    # ----------------------------------------------------------------- clock and randomness
    @property
    def rng(self) -> np.random.Generator:
        """The run's generator, seeded with :attr:`seed`: the only source of randomness."""
        if self._rng is None:
            self._rng = np.random.default_rng(self.seed)
        return self._rng

    @rng.setter
    def rng(self, generator: np.random.Generator) -> None:
        self._rng = generator

    @property
    def time(self) -> float:
        """Simulated seconds since the start of the run."""
        return self.tick * self.time_step

    @property
    def physics_hz(self) -> float:
        """Physics steps per simulated second."""
        return 1.0 / self.time_step

    def step(self) -> None:
        """Advance physics by one step (forces applied since the last step act during it)."""
        m, d = self.compiled()
        for bid, force, point in self._forces:
            mujoco.mj_applyFT(m, d, force, np.zeros(3), point, bid, d.qfrc_applied)
        mujoco.mj_step2(m, d)
        if self._forces:
            d.qfrc_applied[:] = 0.0
            self._forces.clear()
        mujoco.mj_step1(m, d)
        self.tick += 1

    # ----------------------------------------------------------------- compiling
    def compiled(self) -> tuple[Any, Any]:
        """The MuJoCo model and data, compiled now if bodies were added or removed since the last look."""
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
        self._mj_id = {rid: self.model.body(name).id for rid, name in self._mj_name.items()}
        self._apply_damping()
        mujoco.mj_step1(self.model, self.data)

    def _apply_damping(self) -> None:
        m = self.model
        for name, (linear, angular) in self.scene.damping.items():
            body = m.body(name)
            dof = m.jnt_dofadr[body.jntadr[0]]
            if linear is not None:
                m.dof_damping[dof:dof + 3] = float(body.mass[0]) * linear
            if angular is not None:
                m.dof_damping[dof + 3:dof + 6] = np.asarray(body.inertia) * angular

    # ----------------------------------------------------------------- bodies
    def _register(self, name: str, mj_name: str, static: bool) -> int:
        if name in self._bodies:
            raise UserError(f"a body named {name!r} already exists")
        rid = len(self._mj_name) + self.removals
        self._bodies[name], self._names[rid], self._mj_name[rid] = rid, name, mj_name
        if static:
            self._static.add(mj_name)
        self._dirty = True
        return rid

    def add_primitive(self, name: str, shape: str, *, size: Sequence[float] = (0.1, 0.1, 0.1), radius: float = 0.05,
                      height: float = 0.1, mass: float = 1.0, position: Sequence[float] = (0.0, 0.0, 0.0),
                      orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
                      rgba: Sequence[float] = (0.7, 0.7, 0.7, 1.0), mesh_collision: bool = False,
                      **contact: float | None) -> int:
        """A box (``size`` = full edges), sphere or cylinder; ``mass`` 0 makes it static. ``mesh_collision`` is a
        PyBullet speed choice (triangles for its ray casts); MuJoCo keeps the box, which its rays hit exactly."""
        if shape not in ("box", "sphere", "cylinder"):
            raise UserError(f"unknown shape {shape!r}; valid: box, cylinder, sphere")
        if mesh_collision and mass != 0:
            raise UserError("a triangle-mesh collision shape needs mass = 0 (static bodies only)")
        add_primitive(self.scene, name, shape, size=size, radius=radius, height=height, mass=mass,
                      position=position, orientation=orientation, rgba=rgba)
        rid = self._register(name, name, static=mass <= 0)
        self.set_dynamics(rid, -1, **contact)
        return rid

    def resolve_urdf(self, urdf: str) -> str:
        """A model file relative to the config folder, robokit's bundled data or ``pybullet_data``."""
        import pybullet_data

        from robokit.core.world import DATA_DIR

        candidates = [self.base_dir / urdf, DATA_DIR / urdf, Path(pybullet_data.getDataPath()) / urdf]
        if Path(urdf).is_absolute():
            candidates = [Path(urdf)]
        for cand in candidates:
            if cand.is_file():
                return str(cand.resolve())
        raise UserError(f"URDF {urdf!r} not found (looked in {', '.join(str(c.parent) for c in candidates)})")

    def load_urdf(self, name: str, urdf: str, *, position: Sequence[float] = (0.0, 0.0, 0.0),
                  orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0), fixed_base: bool = False, scale: float = 1.0,
                  self_collision: bool = False) -> int:
        """Load a URDF (links become bodies ``NAME/LINK``) and register it under ``name``."""
        if scale != 1.0:
            raise UserError(f"scale = {scale:g}: the mujoco engine loads URDFs at scale 1 only")
        root = load_urdf(self.scene, name, Path(self.resolve_urdf(urdf)), position=position,
                         orientation=orientation, fixed_base=fixed_base, self_collision=self_collision)
        return self._register(name, root.name, static=not root.joints)

    def set_dynamics(self, body: int | str, link: int = -1, **params: float | None) -> None:
        """Contact and damping parameters of a body's base (``link`` -1), PyBullet's names in snake_case."""
        if link != -1:
            raise UserError("the mujoco engine sets dynamics on a body's base only")
        params = {k: v for k, v in params.items() if v is not None}
        if not params:
            return
        mj_name = self._mj_name[self.body(body)]
        if "mass" in params:
            raise UserError("the mujoco engine cannot change a body's mass after it is built")
        linear, angular = params.pop("linear_damping", None), params.pop("angular_damping", None)
        if linear is not None or angular is not None:
            if mj_name in self._static:
                return
            old = self.scene.damping.get(mj_name, (None, None))
            self.scene.damping[mj_name] = (linear if linear is not None else old[0],
                                           angular if angular is not None else old[1])
        self.scene.set_contact(self.scene.spec.body(mj_name), params)
        self._dirty = True

    def remove_body(self, name: str) -> None:
        """Remove a body from the scene and the registry (the scene is recompiled, the others keep their state)."""
        rid = self.body(name)
        self.compiled()
        mj_name = self._mj_name.pop(rid)
        for geom in self.scene.geoms_of(self.scene.spec.body(mj_name)):
            self.scene.contacts.pop(geom.name, None)
        self.scene.spec.delete(self.scene.spec.body(mj_name))
        del self._bodies[name], self._names[rid]
        self._static.discard(mj_name)
        self.scene.damping.pop(mj_name, None)
        self.removals += 1
        self._dirty = True

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
        """Registered name of a body id, or None."""
        return self._names.get(body_id)

    def mass(self, body: str | int) -> float:
        """Total mass (kg) of a body and its links; 0 for a static body."""
        rid = self.body(body)
        if self._mj_name[rid] in self._static:
            return 0.0
        m, _ = self.compiled()
        return float(m.body_subtreemass[self._mj_id[rid]])

    # ----------------------------------------------------------------- state
    def _mj(self, body: str | int) -> int:
        self.compiled()
        return self._mj_id[self.body(body)]

    def pose(self, body: str | int, link: int = -1) -> tuple[Vec3, Quat]:
        """Pose of a body's base in its link (URDF) frame: position (m, world) and ``(x, y, z, w)``."""
        if link != -1:
            raise UserError("the mujoco engine reports base poses only (links come with joint support)")
        bid = self._mj(body)
        return _vec(self.data.xpos[bid]), _xyzw(self.data.xquat[bid])

    def com_pose(self, body: str | int, link: int = -1) -> tuple[Vec3, Quat]:
        """Pose of a body's base centre of mass (inertial frame), world frame."""
        bid = self._mj(body)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, self.data.ximat[bid])
        return _vec(self.data.xipos[bid]), _xyzw(quat)

    def link_offset(self, body: str | int) -> tuple[Vec3, Quat] | None:
        """Always None: MuJoCo reports body (link) frames directly."""
        return None

    def velocity(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Linear velocity of the base's centre of mass (m/s) and angular velocity (rad/s), world frame."""
        bid = self._mj(body)
        out = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_BODY, bid, out, 0)
        return _vec(out[3:]), _vec(out[:3])

    def set_pose(self, body: str | int, position: Sequence[float], orientation: Sequence[float] | None = None) -> None:
        """Teleport a free body's base (velocity zeroed). For set-up and tests, not for control."""
        bid = self._mj(body)
        m, d = self.model, self.data
        if m.body_jntnum[bid] == 0 or m.jnt_type[m.body_jntadr[bid]] != mujoco.mjtJoint.mjJNT_FREE:
            raise UserError(f"body {self._label(body)!r} is static: it cannot be moved on the mujoco engine")
        joint = m.body_jntadr[bid]
        qadr, dadr = m.jnt_qposadr[joint], m.jnt_dofadr[joint]
        d.qpos[qadr:qadr + 3] = list(position)
        if orientation is not None:
            d.qpos[qadr + 3:qadr + 7] = mj_quat(orientation)
        d.qvel[dadr:dadr + 6] = 0.0
        mujoco.mj_step1(m, d)

    def aabb(self, body: str | int, link: int = -1) -> tuple[Vec3, Vec3]:
        """Axis-aligned box ``(min, max)`` around a body and its links (m, world frame)."""
        return self.body_aabb(body)

    def body_aabb(self, body: str | int) -> tuple[Vec3, Vec3]:
        """Axis-aligned box around every geom of a body and its links; a plane counts as its ±1 mm slab."""
        bid = self._mj(body)
        m, d = self.model, self.data
        geoms = [g for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] == m.body_rootid[bid]]
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for g in geoms:
            centre, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
            rot = d.geom_xmat[g].reshape(3, 3)
            mid = d.geom_xpos[g] + rot @ centre
            ext = np.abs(rot) @ half
            lo, hi = np.minimum(lo, mid - ext), np.maximum(hi, mid + ext)
        if not geoms:
            lo = hi = d.xpos[bid]
        return _vec(lo), _vec(hi)

    def apply_force(self, body: str | int, force: Sequence[float], *, position: Sequence[float] | None = None,
                    link: int = -1) -> None:
        """Apply a force (N, world frame) at a world point (default: the centre of mass) during the next step."""
        bid = self._mj(body)
        at = np.asarray(position if position is not None else self.data.xipos[bid], dtype=float)
        self._forces.append((bid, np.asarray(force, dtype=float), at))

    def debug_line(self, start: Sequence[float], end: Sequence[float], rgb: Sequence[float], *,
                   lifetime: float = 0.0) -> None:
        """No-op: the mujoco engine has no GUI in robokit."""

    def _label(self, body: str | int) -> str:
        return body if isinstance(body, str) else (self.body_name(body) or f"body {body}")

    # ----------------------------------------------------------------- lifetime
    def close(self) -> None:
        """Drop the model and data. Safe to call twice."""
        self.model = self.data = None

    def __enter__(self) -> MujocoWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
