"""Record exports and plots turn things the way the world does: a rotation matrix of a quaternion rotates a vector
as the quaternion does (checked by a plain quaternion product), and a yawed box's outline on the map has its
corners where the rotated box has them (checked against the box's corners rotated by hand)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.record.export import rr_matrix
from robokit.record.plots import _box_outline


def _qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def _rotate(q, v):
    """v rotated by q as q * (v, 0) * conj(q): an oracle independent of any matrix formula."""
    conj = (-q[0], -q[1], -q[2], q[3])
    x, y, z, _ = _qmul(_qmul(q, (*v, 0.0)), conj)
    return np.array([x, y, z])


QUATS = [tuple(np.asarray(q) / np.linalg.norm(q)) for q in
         np.random.default_rng(4).normal(size=(12, 4))]


@pytest.mark.parametrize("q", QUATS[:6])
def test_rerun_rotation_matrix_rotates_like_its_quaternion(q):
    m = np.asarray(rr_matrix(q))
    for v in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.3, -0.7, 0.2)):
        np.testing.assert_allclose(m @ np.asarray(v), _rotate(q, v), atol=1e-9)


@pytest.mark.parametrize("yaw_deg", [30.0, 75.0, -120.0])
def test_map_outline_of_a_yawed_box_has_the_rotated_corners(yaw_deg):
    yaw = math.radians(yaw_deg)
    size, px, py = (0.4, 0.1, 0.2), 1.5, -0.5
    pose = np.array([px, py, 0.1, 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    outline = _box_outline(size, pose)
    want = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        hx, hy = sx * size[0] / 2, sy * size[1] / 2
        want.append((px + hx * math.cos(yaw) - hy * math.sin(yaw), py + hx * math.sin(yaw) + hy * math.cos(yaw)))
    got = {(round(x, 9), round(y, 9)) for x, y in outline[:4]}
    assert got == {(round(x, 9), round(y, 9)) for x, y in want}
