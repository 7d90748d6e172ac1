"""Kinematics on the mujoco engine: the chain of frames from the world to a link (for robokit's numpy forward
kinematics and differential IK: MuJoCo has no IK call of its own) and the Jacobian from MuJoCo's ``mj_jacBodyCom``."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.engines.interface import ChainFrame, ChainJoint
from robokit.engines.mujoco.gl import mujoco
from robokit.errors import UserError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from robokit.engines.mujoco.bodies import MujocoBodies

TYPES = {int(mujoco.mjtJoint.mjJNT_HINGE): "revolute", int(mujoco.mjtJoint.mjJNT_SLIDE): "prismatic"}


def _xyzw(q: Any) -> tuple[float, float, float, float]:
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _vec(v: Any) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def kinematic_chain(world: MujocoBodies, body: int, link: int) -> list[ChainFrame | ChainJoint]:
    """The base's pose now, then per body down to ``link``: its fixed placement in its parent and its joint's motion
    (MuJoCo's URDF import puts each joint at its child body's origin)."""
    m, d = world.compiled()
    root = world.mj_body(body)
    path = []
    bid = world.mj_body(body, link)
    while bid != root:
        path.append(bid)
        bid = int(m.body_parentid[bid])
        if bid == 0:
            raise UserError(f"link {link} is not below the base of {world.body_name(body)!r}")
    owner = world.owners()
    steps: list[ChainFrame | ChainJoint] = [ChainFrame(_vec(d.xpos[root]), _xyzw(d.xquat[root]))]
    for bid in reversed(path):
        steps.append(ChainFrame(_vec(m.body_pos[bid]), _xyzw(m.body_quat[bid])))
        for jid in range(m.body_jntadr[bid], m.body_jntadr[bid] + m.body_jntnum[bid]):
            if np.abs(m.jnt_pos[jid]).max() > 1e-12:
                raise UserError(f"joint {m.joint(jid).name!r} is not at its link's origin: no chain on mujoco")
            steps.append(ChainJoint(owner[bid][1], _vec(m.jnt_axis[jid]), TYPES.get(int(m.jnt_type[jid]), "fixed")))
    return steps


def chain_rows(world: MujocoBodies, body: int, link: int) -> tuple[np.ndarray, np.ndarray, int]:
    """qpos and dof addresses of a body's movable joints (index order) and MuJoCo's body id of ``link``."""
    m, _ = world.compiled()
    jids = [int(m.body_jntadr[world.mj_body(body, j.index)]) for j in world.joints(body) if j.movable]
    return (np.array([m.jnt_qposadr[j] for j in jids], dtype=np.int64),
            np.array([m.jnt_dofadr[j] for j in jids], dtype=np.int64), world.mj_body(body, link))


def jacobian(world: MujocoBodies, rows: tuple[np.ndarray, np.ndarray, int], positions: Sequence[float],
             scratch: Any) -> tuple[np.ndarray, np.ndarray]:
    """Linear and angular Jacobian (3 x n each) of a link's link-frame origin (its MuJoCo body's frame, as
    ``World.pose`` gives it) at the movable joints' ``positions``, columns in joint index order (``rows``: from
    :func:`chain_rows`). At the world's own joint positions it is read from the world's state (its kinematics are
    those of its positions); elsewhere it is computed in ``scratch``, an ``MjData`` of the compiled model kept for
    this (the world does not move; mocap bodies stand where the model puts them)."""
    m, d = world.compiled()
    qadr, dofs, target = rows
    data = d
    if d.qpos[qadr].tolist() != [float(v) for v in positions]:
        data = scratch
        scratch.qpos[:] = d.qpos
        scratch.qpos[qadr] = np.asarray(positions, dtype=float)
        mujoco.mj_kinematics(m, scratch)
        mujoco.mj_comPos(m, scratch)
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jac(m, data, jacp, jacr, data.xpos[target], target)
    return jacp[:, dofs], jacr[:, dofs]


def joint_wrench(model: Any, data: Any, child: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """What body ``child`` receives from its parent through its joint in the last step, ``(Fx, Fy, Fz, Mx, My, Mz)``
    in the child's frame, torque about its origin (N, N·m); and that frame's rotation (9 floats, row by row).

    Call right after ``mj_step2`` with ``mj_rnePostConstraint`` done: MuJoCo's ``cfrc_int`` is the force the parent
    exerts, given at the subtree's centre of mass (``subtree_com`` of the root), world orientation, torque first.
    """
    wrench = data.cfrc_int[child]
    torque_c, force = np.asarray(wrench[:3]), np.asarray(wrench[3:])
    centre = data.subtree_com[model.body_rootid[child]]
    origin = data.xpos[child]
    torque = torque_c + np.cross(centre - origin, force)
    rot = np.asarray(data.xmat[child]).reshape(3, 3)
    local = np.concatenate([rot.T @ force, rot.T @ torque])
    return tuple(float(v) for v in local), tuple(float(v) for v in rot.reshape(-1))


def ik_rows(world: MujocoBodies, body: int, link: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """What :func:`inverse_kinematics` looks up: the qpos and dof addresses of a body's movable joints (index order),
    their lower and upper limits (infinite for a joint without) and MuJoCo's body id of ``link``."""
    m, _ = world.compiled()
    movable = [j.index for j in world.joints(body) if j.movable]
    jids = [int(m.body_jntadr[world.mj_body(body, j)]) for j in movable]
    qadr = np.array([m.jnt_qposadr[j] for j in jids], dtype=np.int64)
    dofs = np.array([m.jnt_dofadr[j] for j in jids], dtype=np.int64)
    limited = m.jnt_limited[jids].astype(bool)
    lower = np.where(limited, m.jnt_range[jids, 0], -np.inf)
    upper = np.where(limited, m.jnt_range[jids, 1], np.inf)
    return qadr, dofs, lower, upper, world.mj_body(body, link)


def inverse_kinematics(world: MujocoBodies, rows: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int],
                       position: Sequence[float], orientation: Sequence[float], seed: Sequence[float],
                       damping: Sequence[float], iterations: int, tolerance: float, scratch: Any) -> list[float]:
    """Damped least squares on MuJoCo's Jacobian (Levenberg-Marquardt: ``(J^T J + diag(damping)) dq = J^T e``,
    ``e`` the position error and rotation vector of the link's link frame; ``rows``: from :func:`ik_rows`), from
    ``seed`` (one value per movable joint), each step clipped to the joints' limits, at most ``iterations`` steps,
    stopping once the error's norm is below ``tolerance``. The caller checks the answer. Computed in ``scratch``
    (the world does not move)."""
    m, d = world.compiled()
    qadr, dofs, lower, upper, target = rows
    goal_pos = np.asarray(position, dtype=float)
    goal_quat = np.array([orientation[3], orientation[0], orientation[1], orientation[2]], dtype=float)
    q = np.asarray(seed, dtype=float).copy()
    scratch.qpos[:] = d.qpos
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    error, rot, inverse = np.zeros(6), np.zeros(3), np.zeros(4)
    weights = np.diag(np.asarray(damping, dtype=float))
    qpos, position_of, quaternion_of = scratch.qpos, scratch.xpos[target], scratch.xquat[target]  # views
    for _ in range(iterations):
        qpos[qadr] = q
        mujoco.mj_kinematics(m, scratch)
        error[:3] = goal_pos - position_of
        mujoco.mju_negQuat(inverse, quaternion_of)
        difference = np.zeros(4)
        mujoco.mju_mulQuat(difference, goal_quat, inverse)
        mujoco.mju_quat2Vel(rot, difference, 1.0)
        error[3:] = rot
        if math.sqrt(error @ error) < tolerance:  # np.linalg.norm's arithmetic, without its dispatch
            break
        mujoco.mj_comPos(m, scratch)
        mujoco.mj_jac(m, scratch, jacp, jacr, position_of, target)
        jac = np.concatenate((jacp[:, dofs], jacr[:, dofs]))
        step = np.linalg.solve(jac.T @ jac + weights, jac.T @ error)
        q = np.minimum(np.maximum(q + step, lower), upper)  # np.clip's arithmetic, without its dispatch
    return q.tolist()
