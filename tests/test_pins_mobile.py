"""lidar and collector promises from geometry: the sensor's yaw offset and heading, noisy ranges kept inside
[range_min, range_max]; the collector's reach zone in the robot's frame (rotation, sides, height) and loose bodies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.msgs.mobile import LaserScan
from robokit.testing import PLANE, make_sim

WALL_X = 2.0  # near face of a wall across +x, m


def lidar_scene(yaw_deg: float = 0.0, **lidar: object) -> dict:
    return {
        "bodies": {"plane": PLANE,
                   "wall": {"shape": "box", "size": [0.1, 8.0, 0.5], "mass": 0, "position": [WALL_X + 0.05, 0, 0.25]}},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06], "rpy_deg": [0, 0, yaw_deg]}},
        "sensors": {"scan": {"type": "lidar", "rate_hz": 10, **lidar}},
    }


def ray_at(scan: LaserScan, angle: float) -> int:
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    return int(np.argmin(np.abs(np.remainder(angles - angle + math.pi, 2 * math.pi) - math.pi)))


def test_yaw_offset_turns_the_sensor_counter_clockwise() -> None:
    """Sensor turned +90 deg (to the robot's left): the wall straight ahead (+x) is at scan angle -90 deg, and the
    scan's heading is +90 deg."""
    with make_sim(lidar_scene(rays=360, range_max=6.0, yaw_offset_deg=90.0)) as sim:
        scan = sim.readings["scan"]
    ahead = scan.ranges[ray_at(scan, -math.pi / 2)]
    assert ahead == pytest.approx(WALL_X - scan.origin[0], abs=0.01)
    assert np.isinf(scan.ranges[ray_at(scan, math.pi / 2)])  # behind the robot: nothing within 6 m
    assert scan.yaw == pytest.approx(math.pi / 2, abs=1e-6)


@pytest.mark.parametrize("yaw_deg", [30.0, -50.0])
def test_heading_is_the_robots_yaw(yaw_deg: float) -> None:
    with make_sim(lidar_scene(yaw_deg, rays=36)) as sim:
        scan = sim.readings["scan"]
    assert scan.yaw == pytest.approx(math.radians(yaw_deg), abs=1e-4)


def test_noisy_ranges_stay_within_the_sensor_limits() -> None:
    """Noise of 0.5 m on a wall 5 cm inside range_max: no range above range_max or below range_min."""
    with make_sim(lidar_scene(rays=90, fov_deg=60.0, range_min=0.3, range_max=2.0, range_noise=0.5)) as sim:
        scan = sim.readings["scan"]
    hits = scan.ranges[np.isfinite(scan.ranges)]
    assert len(hits) > 20
    assert hits.max() <= 2.0 and hits.min() >= 0.3
    assert (hits == 2.0).any()  # some were clipped: without the clamp they would lie above


# ------------------------------------------------------------------ collector
def collector_scene(yaw_deg: float, objects: dict[str, list[float]], extra: dict | None = None) -> dict:
    bodies = {"plane": PLANE, **(extra or {})}
    for name, pos in objects.items():
        bodies[name] = {"shape": "box", "size": [0.04, 0.04, 0.04], "mass": 0.05, "position": pos}
    return {"bodies": bodies,
            "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06], "rpy_deg": [0, 0, yaw_deg]}},
            "actuators": {"collector": {"type": "collector", "armed": True}}}


def collected(cfg: dict, ticks: int = 3) -> tuple[int, list[str]]:
    with make_sim(cfg) as sim:
        sim.step(ticks)
        state = sim.readings["collector"]
        return state.count, list(sim.components["collector"].held)


def test_reach_zone_turns_with_the_robot() -> None:
    """Robot facing +y: a can 0.2 m along +y is in front (taken); one 0.2 m along +x is 0.2 m to its right
    (half-width 0.12 m: left alone)."""
    count, held = collected(collector_scene(90.0, {"front": [0.0, 0.2, 0.02], "right": [0.2, 0.0, 0.02]}))
    assert held == ["front"] and count == 1


@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_reach_zone_is_bounded_on_both_sides(side: float) -> None:
    count, _ = collected(collector_scene(0.0, {"beside": [0.2, 0.25 * side, 0.02]}))
    assert count == 0


def test_reach_height_and_static_bodies() -> None:
    """A static shelf in the zone is never taken (mass 0), nor a can on top of it 0.42 m above the base
    (reach_height 0.3 m); a can on the floor in the zone is."""
    shelf = {"shelf": {"shape": "box", "size": [0.06, 0.06, 0.44], "mass": 0, "position": [0.22, 0.05, 0.22]}}
    cfg = collector_scene(0.0, {"high": [0.22, 0.05, 0.465], "low": [0.2, -0.06, 0.02]}, shelf)
    count, held = collected(cfg)
    assert held == ["low"] and count == 1
