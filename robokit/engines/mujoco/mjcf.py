"""MJCF files on the mujoco engine: every top-level body of the file's worldbody becomes a robokit body (``NAME``,
``NAME_1`` …), placed as the file places it relative to the first, the whole file moved so that the first base's
frame is at the requested pose. robokit drives joints with its own motors: the file's actuators are left out."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from robokit.engines.mujoco import spatial as mm
from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.scene import Scene, add_motor, mj_quat, scale_spec
from robokit.errors import UserError


def _xyzw(q: Sequence[float]) -> tuple[float, float, float, float]:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def load_mjcf(scene: Scene, names: list[str], path: Path, *, position: Sequence[float],
              orientation: Sequence[float], fixed_base: bool, scale: float) -> list[tuple[mujoco.MjsBody, list[str]]]:
    """Attach each top-level body of an MJCF file under its robokit name (``names[k]`` for the k-th; the list is
    cut to the file's count): returns per body its root and its other links' names.

    Raises:
        UserError: MuJoCo cannot read the file, or it holds no body.
    """
    try:
        child = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:  # noqa: BLE001 - MuJoCo raises plain exceptions with its parser's message
        reason = str(exc).strip().splitlines()[0]
        raise UserError(f"MJCF {path.name!r} could not be loaded by MuJoCo: {reason}") from None
    tops = list(child.worldbody.bodies)
    if not tops:
        raise UserError(f"MJCF {path.name!r} holds no body")
    for actuator in list(child.actuators):
        child.delete(actuator)
    if scale != 1.0:
        scale_spec(child, scale)
    for i, geom in enumerate(child.geoms):
        geom.name = f"g{i}"
    first = (tuple(float(v) for v in tops[0].pos), _xyzw(tops[0].quat))
    place = mm.multiply(position, orientation, *mm.invert(*first))
    out = []
    for k, top in enumerate(tops[:len(names)]):
        part = child.copy()
        for other in list(part.worldbody.bodies):
            if other.name != top.name:
                part.delete(other)
        root = part.worldbody.first_body()
        if fixed_base:
            for joint in list(root.joints):
                if joint.type == mujoco.mjtJoint.mjJNT_FREE:
                    part.delete(joint)
        frame = scene.spec.worldbody.add_frame(pos=list(place[0]), quat=mj_quat(place[1]))
        scene.spec.attach(part, prefix=f"{names[k]}/", frame=frame)
        attached = scene.spec.body(f"{names[k]}/{top.name}")
        links = [b for b in attached.find_all(mujoco.mjtObj.mjOBJ_BODY) if b.name != attached.name]
        for link in links:
            for joint in link.joints:
                if joint.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                    add_motor(scene.spec, joint.name)
        out.append((attached, [b.name[len(names[k]) + 1:] for b in links]))
    return out
