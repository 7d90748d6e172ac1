"""Pose arithmetic and camera matrices for the mujoco engine, in numpy: robokit's quaternions ``(x, y, z, w)``,
rotation matrices row by row, OpenGL matrices column-major (as the World interface states them)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def quat_mul(a: Sequence[float], b: Sequence[float]) -> Quat:
    """Hamilton product ``a * b`` of ``(x, y, z, w)`` quaternions (b first, then a)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def rotate(q: Sequence[float], v: Sequence[float]) -> Vec3:
    """Vector ``v`` rotated by quaternion ``q``."""
    m = np.asarray(matrix(q)).reshape(3, 3) @ np.asarray(v, dtype=float)
    return (float(m[0]), float(m[1]), float(m[2]))


def matrix(q: Sequence[float]) -> tuple[float, ...]:
    """3x3 rotation matrix of ``(x, y, z, w)``, 9 floats row by row."""
    x, y, z, w = (float(v) for v in q)
    return (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y))


def multiply(pa: Sequence[float], qa: Sequence[float], pb: Sequence[float], qb: Sequence[float]) -> tuple[Vec3, Quat]:
    """Frame B given in frame A, A in the world -> B in the world."""
    r = rotate(qa, pb)
    return (float(pa[0]) + r[0], float(pa[1]) + r[1], float(pa[2]) + r[2]), quat_mul(qa, qb)


def invert(p: Sequence[float], q: Sequence[float]) -> tuple[Vec3, Quat]:
    """The inverse of a pose."""
    qi = (-float(q[0]), -float(q[1]), -float(q[2]), float(q[3]))
    r = rotate(qi, p)
    return (-r[0], -r[1], -r[2]), qi


def from_euler(rpy: Sequence[float]) -> Quat:
    """Quaternion of roll, pitch, yaw (rad) about the fixed x, y, z axes (yaw applied last)."""
    r, p, y = (float(v) / 2.0 for v in rpy)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


def to_euler(q: Sequence[float]) -> Vec3:
    """Roll, pitch, yaw (rad) of a quaternion (the inverse of :func:`from_euler`)."""
    x, y, z, w = (float(v) for v in q)
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def look_at(eye: Sequence[float], target: Sequence[float], up: Sequence[float]) -> tuple[float, ...]:
    """OpenGL view matrix (column-major) of a camera at ``eye`` looking at ``target``."""
    e, t, u = (np.asarray(v, dtype=float) for v in (eye, target, up))
    f = (t - e) / np.linalg.norm(t - e)
    s = np.cross(f, u)
    s /= np.linalg.norm(s)
    u2 = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u2, -f
    m[:3, 3] = -m[:3, :3] @ e
    return tuple(float(v) for v in m.T.reshape(-1))


def perspective(fov_deg: float, aspect: float, near: float, far: float) -> tuple[float, ...]:
    """OpenGL projection matrix (column-major): vertical field of view in degrees."""
    f = 1.0 / math.tan(math.radians(fov_deg) / 2.0)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return tuple(float(v) for v in m.T.reshape(-1))
