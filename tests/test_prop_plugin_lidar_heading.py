"""A world-fixed lidar's heading and points (docs/mobile.md: ``position`` + ``rpy_deg``; the scan's ``yaw`` is the
sensor's heading about world +z), over generated orientations that are no rotation's own inverse.

Oracle: the sensor's rotation written here as ``Rz @ Ry @ Rx`` from ``rpy_deg``; its heading is where its +x axis
points seen from above; a level sensor's points are its origin plus each range along ``yaw + angle``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.testing import make_sim


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def generated_orientations(n: int, seed: int) -> list[tuple[float, float, float]]:
    """Yaws away from 0 and 180 degrees, half of them level, half tilted about both other axes."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        yaw = float(rng.uniform(15, 165) * rng.choice([-1, 1]))
        tilt = (0.0, 0.0) if k % 2 == 0 else (float(rng.uniform(-30, 30)), float(rng.uniform(-30, 30)))
        out.append((*tilt, yaw))
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_a_world_fixed_lidar_reports_its_own_heading_and_points_along_it(seed: int) -> None:
    rpys = generated_orientations(6, seed)
    sensors = {f"scan{k}": {"type": "lidar", "rays": 24, "range_max": 3.0, "position": [0.0, 0.0, 0.3],
                            "rpy_deg": list(rpy)} for k, rpy in enumerate(rpys)}
    cfg = {"bodies": {"ball": {"shape": "sphere", "radius": 0.5, "mass": 0, "position": [1.2, 0.7, 0.3]}},
           "sensors": sensors}
    with make_sim(cfg) as sim:
        for k, rpy in enumerate(rpys):
            rot = rpy_matrix(*np.radians(rpy))
            scan = sim.components[f"scan{k}"].read()
            assert abs(math.remainder(scan.yaw - math.atan2(rot[1, 0], rot[0, 0]), 2 * math.pi)) < 1e-6, rpy
            if rpy[0] == 0.0 and rpy[1] == 0.0:  # level: the scan's points lie along yaw + each ray's angle
                angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
                hit = np.isfinite(scan.ranges)
                assert hit.any(), "the ball is in every level scan"
                drawn = np.stack([np.cos(scan.yaw + angles), np.sin(scan.yaw + angles)], axis=1)
                drawn = np.asarray(scan.origin)[:2] + drawn * np.asarray(scan.ranges)[:, None]
                assert np.allclose(drawn[hit], np.asarray(scan.points)[hit][:, :2], atol=1e-4)
                # and on the ball: within its radius of its centre, seen from the side
                assert np.all(np.linalg.norm(drawn[hit] - [1.2, 0.7], axis=1) < 0.5 + 1e-3)
