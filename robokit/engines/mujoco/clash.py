"""Collision checks of arm configurations on the mujoco engine (:meth:`World.clashes`): the configuration is put
into a scratch ``MjData`` (the world's own data is not touched), MuJoCo's forward kinematics places every geom, and
``mj_geomDistance`` measures each pair of a moving geom and another body's geom whose bounding spheres come
within the margin."""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.engines.interface import Clash, Pose
from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.spatial import multiply

if TYPE_CHECKING:
    from robokit.engines.mujoco.bodies import MujocoBodies


def _wxyz(q: Sequence[float]) -> list[float]:
    return [float(q[3]), float(q[0]), float(q[1]), float(q[2])]


def clashes(world: MujocoBodies, scratch: Any, body: int, joints: Sequence[int], positions: Sequence[float], *,
            carried: Sequence[tuple[int, int, Pose]], skip: Collection[int], margin: float) -> list[Clash]:
    """:meth:`World.clashes` computed in ``scratch``, an ``MjData`` of the compiled model."""
    m, d = world.compiled()
    scratch.qpos[:] = d.qpos
    if m.nmocap:  # a static body moved (a mocap body now): where it stands, not where the model put it
        scratch.mocap_pos[:], scratch.mocap_quat[:] = d.mocap_pos, d.mocap_quat
    for joint, q in zip(joints, positions, strict=True):
        scratch.qpos[m.jnt_qposadr[int(m.body_jntadr[world.mj_body(body, joint)])]] = q
    mujoco.mj_kinematics(m, scratch)
    for held, link, (pos, orn) in carried:
        lb = world.mj_body(body, link)
        link_pose = (scratch.xpos[lb].tolist(), (*scratch.xquat[lb][1:].tolist(), float(scratch.xquat[lb][0])))
        com = multiply(*link_pose, pos, orn)
        offset = world.link_offset(held)
        frame = com if offset is None else multiply(*com, *offset)
        adr = int(m.jnt_qposadr[int(m.body_jntadr[world.mj_body(held)])])
        scratch.qpos[adr:adr + 3] = frame[0]
        scratch.qpos[adr + 3:adr + 7] = _wxyz(frame[1])
    if carried:
        mujoco.mj_kinematics(m, scratch)
    owners = world.owners()
    owner = np.array([owners.get(int(b), (-1, -1))[0] for b in m.geom_bodyid])
    links = np.array([owners.get(int(b), (-1, -1))[1] for b in m.geom_bodyid])
    solid = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    movers = [body] + [held for held, _, _ in carried]
    moving = np.flatnonzero(solid & np.isin(owner, movers))
    fixed = np.flatnonzero(solid & (owner >= 0) & ~np.isin(owner, [*movers, *skip]))
    centres, radii = scratch.geom_xpos, m.geom_rbound
    out = []
    for g in moving:
        gap = np.linalg.norm(centres[fixed] - centres[g], axis=1) - radii[fixed] - radii[g]
        near = fixed[(gap < margin) | (radii[fixed] == 0)]  # a plane's bounding radius is 0: always measured
        for h in near:
            dist = mujoco.mj_geomDistance(m, scratch, int(g), int(h), margin + 1e-6, None)
            if dist <= margin:
                out.append(Clash(int(owner[g]), int(links[g]), int(owner[h]), int(links[h]), float(dist)))
    return out
