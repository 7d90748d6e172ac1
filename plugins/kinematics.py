"""Forward kinematics and the geometric Jacobian of one link of a fixed-base arm, in numpy.

Built once from the World's kinematic chain (:meth:`World.kinematic_chain
<robokit.engines.interface.World.kinematic_chain>`, :class:`Chain`), then evaluated for any joint vector without
touching the simulation: no joint state is written and read back, so IK can try candidate configurations between
physics steps for the price of a few 4x4 products. Used by ``ik_arm``; :func:`arm_joints` sets up the joints
of both arm actuators (``ik_arm``, ``ee_delta``).

The engine describes the chain as fixed frames and joint motions in order (how it arrives at them, e.g. PyBullet's
inertial frames, is its own business). Positions in metres, world frame; quaternions ``(x, y, z, w)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from robokit.engines.interface import ChainFrame, JointInfo
from robokit.errors import ConfigError


def transform(position: Sequence[float], quaternion: Sequence[float]) -> np.ndarray:
    """4x4 homogeneous transform of a position and an ``(x, y, z, w)`` quaternion."""
    x, y, z, w = quaternion
    out = np.eye(4)
    out[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    out[:3, 3] = position
    return out


def quaternion_of(rot: np.ndarray) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` quaternion (w >= 0) of a 3x3 rotation matrix."""
    m = rot
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)
    sign = -1.0 if q[3] < 0 else 1.0
    return (float(sign * q[0]), float(sign * q[1]), float(sign * q[2]), float(sign * q[3]))


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """3x3 rotation by ``angle`` radians about a unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ])


def links_to(world: Any, body: int, link: int) -> list[int]:
    """Indices of the links from the base (excluded) out to ``link``, base side first."""
    path = []
    while link >= 0:
        path.append(link)
        link = world.joint_parent(body, link)
    path.reverse()
    return path


class ArmJoints(NamedTuple):
    """An arm actuator's joints, found once at setup (:func:`arm_joints`): what ``ik_arm`` and ``ee_delta`` share.

    Joint vectors over :attr:`movable` (index order) are how both plugins hold a configuration; :attr:`columns`
    picks the arm's joints out of them.
    """

    body: int
    """Body id of the arm."""
    ee: int
    """Link index of the end effector."""
    movable: list[JointInfo]
    """The body's movable joints, index order (a gripper's fingers included)."""
    arm: list[JointInfo]
    """The movable joints on the chain from the base to the end effector, base first."""

    @property
    def names(self) -> list[str]:
        """Names of the :attr:`movable` joints, in order."""
        return [j.name for j in self.movable]

    @property
    def columns(self) -> list[int]:
        """Where each :attr:`arm` joint stands in a joint vector over the :attr:`movable` joints."""
        names = self.names
        return [names.index(j.name) for j in self.arm]

    def column(self, name: str, key: str) -> int:
        """Where the movable joint ``name`` (a config's joint name) stands in a joint vector.

        Raises:
            ConfigError: At ``key``: no movable joint has that name (the message lists them).
        """
        names = self.names
        if name not in names:
            raise ConfigError(f"unknown joint {name!r}; movable joints: {', '.join(names)}", key=key)
        return names.index(name)

    def forces(self, max_force: float | None) -> list[float]:
        """Motor force (N·m or N) per :attr:`arm` joint: ``max_force``, else the URDF's (100 where it gives none)."""
        return [max_force or (j.max_force if j.max_force > 0 else 100.0) for j in self.arm]


def arm_joints(ctx: Any, body_name: str, ee_link: str) -> ArmJoints:
    """For an arm actuator's setup: body id, end-effector link index, the body's movable joints and those on the
    chain from the base to the end effector (base first). Config errors (at ``body`` / ``ee_link``) for an unknown
    body or link, the base link as end effector, or no movable joint on the chain."""
    body = ctx.body(body_name)
    ee = ctx.link(body_name, ee_link, key="ee_link")
    if ee < 0:
        raise ConfigError(f"the end-effector link must not be the base link {ee_link!r}", key="ee_link")
    movable = [j for j in ctx.world.joints(body_name) if j.movable]
    chain = set(links_to(ctx.world, body, ee))
    arm = [j for j in movable if j.index in chain]
    if not arm:
        raise ConfigError(f"no movable joint between the base and {ee_link!r}", key="ee_link")
    return ArmJoints(body, ee, movable, arm)


class Chain:
    """The joints from a fixed base to one link, folded into constant transforms between the moving joints.

    Args:
        world: The World (read at construction only).
        body: Body id of the arm (its base must not move while the chain is used).
        link: Index of the end link.
        columns: Joint index -> column in the joint vectors passed to :meth:`fk` / :meth:`jacobian`.
        tool: A frame fixed in the end link's URDF frame (position, quaternion): :meth:`fk` and :meth:`jacobian`
            then describe that frame (a tool-centre point) instead of the link's own.
    """

    def __init__(self, world: Any, body: int, link: int, columns: dict[int, int],
                 tool: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        const: np.ndarray | None = None  # frames since the last moving joint (None: none yet)
        self.constants: list[np.ndarray] = []  # frame before each moving joint, relative to the one after the last
        axes, prismatic, cols = [], [], []
        for step in world.kinematic_chain(body, link):
            if isinstance(step, ChainFrame):
                frame = transform(step.position, step.orientation)
                const = frame if const is None else const @ frame
                continue
            col = columns.get(step.joint, -1)
            if col >= 0:
                axis = np.asarray(step.axis, float)
                self.constants.append(const if const is not None else np.eye(4))
                axes.append(axis / max(float(np.linalg.norm(axis)), 1e-12))
                prismatic.append(step.type == "prismatic")
                cols.append(col)
                const = np.eye(4)
        const = const if const is not None else np.eye(4)
        self.tail = const if tool is None else const @ transform(*tool)
        self.axes = np.array(axes).reshape(-1, 3)
        self.prismatic = np.array(prismatic, bool)
        self.columns = cols
        """Columns of the joint vector that move the link, base first (the Jacobian's columns)."""
        a = self.axes
        self._outer = a[:, :, None] * a[:, None, :]
        self._cross = np.zeros((len(a), 3, 3))
        self._cross[:, 0, 1], self._cross[:, 0, 2], self._cross[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
        self._cross -= self._cross.transpose(0, 2, 1)
        self._eye = np.eye(3)

    def _motions(self, q: np.ndarray) -> np.ndarray:
        """4x4 motion of every moving joint at ``q`` (rotations by Rodrigues, all at once)."""
        angles = np.where(self.prismatic, 0.0, q[self.columns])
        c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
        out = np.zeros((len(angles), 4, 4))
        out[:, :3, :3] = c * self._eye + (1.0 - c) * self._outer + s * self._cross
        out[:, :3, 3] = np.where(self.prismatic[:, None], self.axes * q[self.columns][:, None], 0.0)
        out[:, 3, 3] = 1.0
        return out

    def fk_many(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`fk` of many joint vectors at once (rows of ``qs``): positions (m x 3, metres, world) and
        rotation matrices (m x 3 x 3) of the end link's URDF frame. One batched pass: checking a path's
        waypoints costs about what one :meth:`fk` does."""
        qs = np.atleast_2d(qs)
        m, n = len(qs), len(self.columns)
        if n == 0:
            t = np.broadcast_to(self.tail, (m, 4, 4))
            return t[:, :3, 3].copy(), t[:, :3, :3].copy()
        values = qs[:, self.columns]
        angles = np.where(self.prismatic, 0.0, values)
        c, s = np.cos(angles)[:, :, None, None], np.sin(angles)[:, :, None, None]
        motions = np.zeros((m, n, 4, 4))
        motions[:, :, :3, :3] = c * self._eye + (1.0 - c) * self._outer + s * self._cross
        motions[:, :, :3, 3] = np.where(self.prismatic[:, None], self.axes[None, :, :] * values[:, :, None], 0.0)
        motions[:, :, 3, 3] = 1.0
        t = self.constants[0] @ motions[:, 0]
        for i in range(1, n):
            t = t @ self.constants[i] @ motions[:, i]
        t = t @ self.tail
        return t[:, :3, 3].copy(), t[:, :3, :3].copy()

    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The end link's frame (4x4, world), and each moving joint's origin and world axis (n x 3 each)."""
        motions = self._motions(q)
        n = len(self.columns)
        origins, axes = np.empty((n, 3)), np.empty((n, 3))
        t = np.eye(4)
        for i in range(n):
            t = t @ self.constants[i]
            origins[i] = t[:3, 3]
            axes[i] = t[:3, :3] @ self.axes[i]
            t = t @ motions[i]
        return t @ self.tail, origins, axes

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float, float]]:
        """Position (m, world) and orientation ``(x, y, z, w)`` of the end link's URDF frame at joints ``q``."""
        motions = self._motions(q)
        t = self.constants[0] @ motions[0] if len(motions) else np.eye(4)
        for i in range(1, len(motions)):
            t = t @ self.constants[i] @ motions[i]
        t = t @ self.tail
        return t[:3, 3].copy(), quaternion_of(t[:3, :3])

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float, float]]:
        """6 x n geometric Jacobian (linear rows first) of the end link's frame origin over :attr:`columns`,
        with that frame's position and orientation at ``q``."""
        frame, origins, axes = self.frames(q)
        tip = frame[:3, 3].copy()
        linear = np.where(self.prismatic[:, None], axes, np.cross(axes, tip - origins))
        angular = np.where(self.prismatic[:, None], 0.0, axes)
        return np.vstack([linear.T, angular.T]), tip, quaternion_of(frame[:3, :3])
