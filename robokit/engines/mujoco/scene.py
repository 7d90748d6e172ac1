"""Building a MuJoCo scene from robokit bodies with :class:`mujoco.MjSpec`: primitives, URDFs, contact parameters.

Units are SI; quaternions handed in are robokit's ``(x, y, z, w)`` and turned into MuJoCo's ``(w, x, y, z)`` here.

How PyBullet's contact parameters are mapped (MuJoCo's own contact model decides the rest):

* ``lateral_friction``, ``spinning_friction``, ``rolling_friction`` are a geom's ``friction`` (slide, torsional,
  rolling). MuJoCo combines two geoms' friction by the **maximum**; PyBullet multiplies them. Spinning and rolling
  friction switch the geom's contact to ``condim`` 4 / 6 (MuJoCo ignores them at the default 3).
* ``restitution``: MuJoCo has no coefficient of restitution. A pair of geoms whose restitutions multiply (PyBullet's
  rule) to ``e > 0`` gets an explicit contact pair whose reference dynamics are a spring-damper with MuJoCo's default
  contact stiffness (``timeconst`` 0.02 s) and the damping ratio of a linear oscillator that keeps ``e`` of its
  speed, ``zeta = -ln(e) / sqrt(pi^2 + ln(e)^2)``. Pairs with ``e = 0`` keep MuJoCo's default (critically damped)
  contact. The bounce this gives is measured in docs/engines.md, not promised exact.
* ``linear_damping`` / ``angular_damping`` (per second, as PyBullet's) become the free joint's per-dof damping:
  ``mass * rate`` on the translations and ``inertia * rate`` on the rotations.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.grip import GripAnchors
from robokit.engines.mujoco.links import UrdfJoint
from robokit.errors import UserError

DEFAULT_TIMECONST = 0.02
"""MuJoCo's default contact ``solref`` time constant (s): the stiffness restitution pairs keep."""


def mj_quat(q: Sequence[float]) -> list[float]:
    """robokit ``(x, y, z, w)`` -> MuJoCo ``(w, x, y, z)``."""
    return [float(q[3]), float(q[0]), float(q[1]), float(q[2])]


def damping_ratio(restitution: float) -> float:
    """Damping ratio of a linear spring-damper that rebounds with ``restitution`` of its impact speed (1 at 0)."""
    if restitution <= 0.0:
        return 1.0
    log_e = math.log(min(restitution, 0.999))
    return -log_e / math.sqrt(math.pi**2 + log_e**2)


@dataclass
class GeomContact:
    """Contact parameters robokit set on one geom (None: not set, MuJoCo's default)."""

    restitution: float = 0.0
    static: bool = False


@dataclass
class Scene:
    """The spec being built, and what MuJoCo needs from robokit beyond it (restitution, damping rates)."""

    spec: mujoco.MjSpec
    contacts: dict[str, GeomContact] = field(default_factory=dict)
    """Geom name -> its robokit contact parameters."""
    damping: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)
    """Free body name -> (linear, angular) damping rates, 1/s."""
    grips: GripAnchors = field(default_factory=GripAnchors)
    """The fingers' anchors (:mod:`robokit.engines.mujoco.grip`)."""

    @classmethod
    def new(cls, time_step: float, gravity: Sequence[float], iterations: int) -> Scene:
        spec = mujoco.MjSpec()
        spec.compiler.fusestatic = False  # every URDF link stays a body: links are looked up by name
        spec.compiler.degree = False
        spec.option.timestep = time_step
        spec.option.gravity = list(gravity)
        spec.option.iterations = iterations
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER  # motor damping in the constraint solve (links.py)
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC  # MuJoCo's advice for grasping (see set_grip)
        return cls(spec)

    def set_mass(self, body: mujoco.MjsBody, mass: float) -> None:
        """A body's mass (kg): the URDF's inertial (inertia scaled alike), or a primitive's geom."""
        if body.mass > 0 or not body.geoms:  # the inertial a URDF gave
            if body.mass > 0:
                body.inertia = [v * mass / body.mass for v in body.inertia]
            body.mass = mass
            return
        for geom in body.geoms:
            geom.mass = mass / len(body.geoms)

    def restitution(self, geom: str) -> float:
        """The restitution robokit set on a geom (0 if none)."""
        contact = self.contacts.get(geom)
        return contact.restitution if contact is not None else 0.0

    def set_damping(self, body: str, linear: float | None, angular: float | None) -> None:
        """Damping rates (1/s) of a free body's translation and rotation (None: keep what is set)."""
        old = self.damping.get(body, (None, None))
        self.damping[body] = (linear if linear is not None else old[0], angular if angular is not None else old[1])

    def apply_damping(self, model: mujoco.MjModel) -> None:
        """Write the damping rates into a compiled model's free-joint dofs (``mass`` / ``inertia`` times the rate)."""
        for name, (linear, angular) in self.damping.items():
            body = model.body(name)
            if body.jntnum[0] == 0:
                continue
            dof = model.jnt_dofadr[body.jntadr[0]]
            if linear is not None:
                model.dof_damping[dof:dof + 3] = float(body.mass[0]) * linear
            if angular is not None:
                model.dof_damping[dof + 3:dof + 6] = [float(v) * angular for v in body.inertia]

    def geoms_of(self, body: mujoco.MjsBody) -> list[mujoco.MjsGeom]:
        """Every geom of a body and of the bodies below it."""
        return list(body.find_all(mujoco.mjtObj.mjOBJ_GEOM))

    def set_contact(self, body: mujoco.MjsBody, params: Mapping[str, float | None]) -> None:
        """Apply robokit contact parameters (``lateral_friction`` …, ``restitution``) to a body's own geoms."""
        for geom in body.geoms:
            friction = list(geom.friction)
            for slot, key in enumerate(("lateral_friction", "spinning_friction", "rolling_friction")):
                value = params.get(key)
                if value is not None:
                    friction[slot] = float(value)
                    geom.condim = max(geom.condim, (3, 4, 6)[slot])
            geom.friction = friction
            if params.get("restitution") is not None:
                self.contacts.setdefault(geom.name, GeomContact()).restitution = float(params["restitution"] or 0.0)

    def set_grip(self, body: mujoco.MjsBody) -> None:
        """A gripping surface (PyBullet's ``friction_anchor``: contacts that hold what they squeeze): its contacts
        take its own parameters (``priority``) with MuJoCo's stiffest reference, a time constant of two steps
        (``solref``; shorter is not stable), so friction stops a slip within a step; and torsional friction
        (``condim`` 4) so a squeezed object does not pivot; and an anchor that holds a squeezed object where it is in
        the fingers (:mod:`robokit.engines.mujoco.grip`)."""
        self.grips.add(self.spec, body.name)
        for geom in body.geoms:
            geom.priority = 1
            geom.solref = [2.0 * self.spec.option.timestep, 1.0]
            geom.condim = max(geom.condim, 4)

    def add_restitution_pairs(self, static_bodies: set[str]) -> None:
        """One explicit pair for each two geoms (of different bodies, not both static) whose restitutions multiply to
        more than zero."""
        bouncy = [(name, c.restitution) for name, c in self.contacts.items() if c.restitution > 0.0]
        timeconst = max(DEFAULT_TIMECONST, 2.0 * self.spec.option.timestep)
        dmax = 0.95  # MuJoCo's default solimp[1]
        w0 = 1.0 / (dmax * timeconst)
        for i, (g1, e1) in enumerate(bouncy):
            geom1 = self.spec.geom(g1)
            for g2, e2 in bouncy[i + 1:]:
                geom2 = self.spec.geom(g2)
                b1, b2 = _root_name(geom1), _root_name(geom2)
                if b1 == b2 or (b1 in static_bodies and b2 in static_bodies):
                    continue
                pair = self.spec.add_pair(geomname1=g1, geomname2=g2)
                pair.condim = max(geom1.condim, geom2.condim)
                slide, spin, roll = (max(a, b) for a, b in zip(geom1.friction, geom2.friction, strict=True))
                pair.friction = [slide, slide, spin, roll, roll]
                pair.solref = [-(w0**2), -2.0 * damping_ratio(e1 * e2) * w0]


def _root_name(geom: mujoco.MjsGeom) -> str:
    body = geom.parent
    while body.parent is not None and body.parent.name != "world":
        body = body.parent
    return str(body.name)


def add_primitive(scene: Scene, name: str, shape: str, *, size: Sequence[float], radius: float, height: float,
                  mass: float, position: Sequence[float], orientation: Sequence[float],
                  rgba: Sequence[float]) -> mujoco.MjsBody:
    """A body holding one box / sphere / cylinder geom (named ``name``); free unless ``mass`` is 0 (static)."""
    body = scene.spec.worldbody.add_body(name=name, pos=list(position), quat=mj_quat(orientation))
    kinds = {"box": mujoco.mjtGeom.mjGEOM_BOX, "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
             "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER}
    sizes = {"box": [s / 2.0 for s in size], "sphere": [radius, 0.0, 0.0], "cylinder": [radius, height / 2.0, 0.0]}
    geom = body.add_geom(name=name, type=kinds[shape], size=sizes[shape], rgba=list(rgba))
    if mass > 0:
        geom.mass = mass
        body.add_freejoint(name=f"{name}/free")
    return body


def _absolute_meshes(urdf_path: Path) -> str:
    """The URDF's text with every mesh ``filename`` made absolute (``package://x`` is ``x`` beside the URDF, as
    PyBullet reads it) and xacro's ``$(optenv NAME default)`` left in a file replaced by its default."""
    folder = urdf_path.parent

    def fix(match: re.Match[str]) -> str:
        name = match.group(2)
        if name.startswith("package://"):
            name = name[len("package://"):]
        return f"{match.group(1)}{(folder / name).resolve() if not Path(name).is_absolute() else name}\""

    text = re.sub(r'(filename\s*=\s*")([^"]*)"', fix, urdf_path.read_text(encoding="utf-8"))
    return re.sub(r"\$\(optenv\s+\S+\s*([^)]*)\)", r"\1", text)  # xacro left-overs: their default values


def load_urdf(scene: Scene, name: str, path: Path, *, position: Sequence[float], orientation: Sequence[float],
              fixed_base: bool, self_collision: bool, scale: float = 1.0) -> tuple[mujoco.MjsBody, list[str]]:
    """Attach a URDF's links as bodies named ``NAME/LINK`` (geoms ``NAME/gI``, one motor ``NAME/JOINT/motor`` per
    moving joint, switched off); returns the root body and the other links' names in MuJoCo's body order.

    The base is free unless ``fixed_base`` or it has no mass (as PyBullet makes a massless base static). Without
    ``self_collision`` no two links of the robot collide (PyBullet's default); MuJoCo already skips parent and child.

    Raises:
        UserError: MuJoCo's URDF reader refuses the file.
    """
    try:
        child = mujoco.MjSpec.from_string(_absolute_meshes(path))
    except Exception as exc:  # noqa: BLE001 - MuJoCo raises plain exceptions with its parser's message
        raise UserError(f"URDF {path.name!r} could not be loaded by MuJoCo: {_first_line(exc)}") from None
    for i, geom in enumerate(child.geoms):
        geom.name = f"g{i}"
    if scale != 1.0:
        scale_spec(child, scale)
    frame = scene.spec.worldbody.add_frame(pos=list(position), quat=mj_quat(orientation))
    scene.spec.attach(child, prefix=f"{name}/", frame=frame)
    root = next(b for b in scene.spec.bodies if b.name.startswith(f"{name}/"))
    links = [b for b in root.find_all(mujoco.mjtObj.mjOBJ_BODY) if b.name != root.name]
    if not fixed_base and root.mass + sum(b.mass for b in links) > 0:
        root.add_freejoint(name=f"{name}/free")
    if not self_collision:
        group = [root, *links]
        for i, b1 in enumerate(group):
            for b2 in group[i + 1:]:
                scene.spec.add_exclude(bodyname1=b1.name, bodyname2=b2.name)
    for link in links:
        for joint in link.joints:
            add_motor(scene.spec, joint.name)
    return root, [b.name[len(name) + 1:] for b in links]


def mujoco_joints(name: str, links: list[str], spec: mujoco.MjSpec) -> dict[str, UrdfJoint]:
    """The joints MuJoCo read, by child link (for a URDF robokit cannot read itself)."""
    kinds = {mujoco.mjtJoint.mjJNT_HINGE: "revolute", mujoco.mjtJoint.mjJNT_SLIDE: "prismatic"}
    out = {}
    for link in links:
        for joint in spec.body(f"{name}/{link}").joints:
            lower, upper = (float(v) for v in joint.range)
            out[link] = UrdfJoint(joint.name[len(name) + 1:], kinds.get(joint.type, "fixed"), lower, upper,
                                  0.0, 0.0, float(joint.damping[0]), float(joint.frictionloss))
    return out


def scale_spec(spec: mujoco.MjSpec, factor: float) -> None:
    """Scale a model's geometry as PyBullet's ``globalScaling`` does: link placements, shapes and meshes; masses
    stay, inertias scale with the square of the factor."""
    for body in spec.bodies:
        body.pos = [v * factor for v in body.pos]
        body.ipos = [v * factor for v in body.ipos]
        body.inertia = [v * factor * factor for v in body.inertia]
    for geom in spec.geoms:
        geom.pos = [v * factor for v in geom.pos]
        if geom.type != mujoco.mjtGeom.mjGEOM_MESH:
            geom.size = [v * factor for v in geom.size]
    for mesh in spec.meshes:
        mesh.scale = [v * factor for v in mesh.scale]
    for joint in spec.joints:
        joint.pos = [v * factor for v in joint.pos]


def add_motor(spec: mujoco.MjSpec, joint: str) -> None:
    """A joint motor whose gains the engine sets when a plugin drives the joint (zero: no force)."""
    motor = spec.add_actuator(name=f"{joint}/motor", target=joint)
    motor.trntype = mujoco.mjtTrn.mjTRN_JOINT
    motor.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    motor.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    motor.gainprm = [0.0] * len(motor.gainprm)
    motor.biasprm = [0.0] * len(motor.biasprm)
    motor.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    motor.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return "; ".join(lines[:2]) or type(exc).__name__
