"""patrol and patrol_collect: waypoints in order, an unknown object found once and collected, the shipped scene."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main
from robokit.testing import PLANE, make_sim

ROOT = Path(__file__).resolve().parents[1]


def arena(behaviour: dict, **extra_bodies: dict) -> dict:
    """A 5 m x 4 m walled room with one box in the middle; the diffbot at (0, 0) facing +x."""
    def wall(x: float, y: float, sx: float, sy: float) -> dict:
        return {"shape": "box", "size": [sx, sy, 0.4], "mass": 0, "position": [x, y, 0.2]}

    return {
        "world": {"max_time": 120},
        "bodies": {"plane": PLANE, "wall_s": wall(1.5, -1.55, 5.2, 0.1), "wall_n": wall(1.5, 2.55, 5.2, 0.1),
                   "wall_w": wall(-1.05, 0.5, 0.1, 4.2), "wall_e": wall(4.05, 0.5, 0.1, 4.2),
                   "box": {"shape": "box", "size": [0.8, 0.8, 0.5], "mass": 0, "position": [1.5, 0.5, 0.25]},
                   **extra_bodies},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
        "sensors": {"scan": {"type": "lidar", "rate_hz": 10}, "bump": {"type": "contact", "body": "robot"}},
        "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60},
                      "collector": {"type": "collector", "rate_hz": 20}},
        "behaviour": {"rate_hz": 20, "contact_sensor": "bump", **behaviour},
    }


def waypoint_trace(sim) -> list[int]:
    return [r["waypoint"] for r in sim.trace if r["kind"] == "waypoint_reached"]


@pytest.mark.slow
def test_patrol_visits_waypoints_in_order() -> None:
    cfg = arena({"type": "patrol", "waypoints": [[3.0, 0.5], [1.5, 1.9], [0.0, 0.5]], "laps": 2})
    with make_sim(cfg) as sim:
        result = sim.run()
        assert result.outcome == "succeeded", result.reason
        assert waypoint_trace(sim) == [0, 1, 2, 0, 1, 2]
        assert result.result["waypoints_reached"] == 6 and result.result["collisions"] == 0
        assert result.result["distance_travelled"] > 2 * 6.0


def test_object_on_the_route_is_found_logged_once_and_collected() -> None:
    can = {"shape": "cylinder", "radius": 0.05, "height": 0.2, "mass": 0.2, "position": [3.0, -0.9, 0.1]}
    cfg = arena({"type": "patrol_collect", "waypoints": [[3.2, -0.9], [3.0, 1.9]], "truth_sensor": "truth"},
                can=can)
    cfg["sensors"]["truth"] = {"type": "body_pose", "bodies": ["can"]}
    with make_sim(cfg) as sim:
        result = sim.run()
        r = result.result
        assert result.outcome == "succeeded", result.reason
        logged = [rec for rec in sim.trace if rec["kind"] == "object_found"]
        assert len(logged) == 1 and r["objects_found"] == 1  # logged once, though seen in many scans
        assert r["objects_collected"] == 1 and r["collisions"] == 0
        est = logged[0]["estimate"]
        assert math.dist(est, (3.0, -0.9)) < 0.05  # the estimate came from the scan alone
        assert r["found"][0]["error"] < 0.05
        assert "APPROACHING" in sim.behaviour.visited
        # the can is in the robot's bin now, not on the floor where it was
        (x, y, z), _ = sim.world.pose("can")
        rx, ry, _ = sim.readings["drive"].pose
        assert math.hypot(x - rx, y - ry) < 0.2 and z > 0.1
        assert r["waypoints_reached"] == 2


def test_waypoint_inside_an_obstacle_is_one_line_at_validate(tmp_path, capsys) -> None:
    text = (ROOT / "configs" / "patrol_robot.toml").read_text()
    bad = text.replace("waypoints = [[5.0, 3.0],", "waypoints = [[4.0, 1.6],")
    assert bad != text
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "behaviour.waypoints[0]" in err and "inside obstacle 'box_c'" in err


@pytest.mark.slow  # the whole lesson config through the CLI: the slow tier
def test_patrol_robot_config_runs_headless_and_exits_0(tmp_path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "robokit.cli", "run", str(ROOT / "configs" / "patrol_robot.toml"), "--seed", "4"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "outcome: succeeded" in proc.stdout
    assert "objects_collected: 4" in proc.stdout and "collisions: 0" in proc.stdout


def test_behaviours_import_no_pybullet() -> None:
    code = ("import sys, robokit_behaviours.go_to_goal, robokit_behaviours.patrol, robokit_behaviours.patrol_collect; "
            "sys.exit(int(any(m.startswith('pybullet') for m in sys.modules)))")
    assert subprocess.run([sys.executable, "-c", code], timeout=60).returncode == 0


def synthetic_scan(points: list[tuple[float, float]]):
    """A LaserScan from the origin whose hits are exactly ``points`` (world xy, z = 0.12), in angle order."""
    import numpy as np

    from robokit.msgs.mobile import LaserScan

    pts = sorted(points, key=lambda p: math.atan2(p[1], p[0]))
    xyz = np.array([[x, y, 0.12] for x, y in pts])
    ranges = np.hypot(xyz[:, 0], xyz[:, 1])
    return LaserScan(-math.pi, math.pi, 0.01, 0.05, 5.0, ranges, xyz, (0.0, 0.0, 0.12), 0.0, 0.0)


def test_discovery_ignores_the_known_map_and_large_unknowns() -> None:
    from robokit_behaviours.discovery import Discovery, DiscoveryConfig

    can = [(2.0 + 0.05 * math.cos(a), 0.05 * math.sin(a)) for a in (2.6, 2.9, 3.1416, 3.4, 3.7)]
    wall = [(3.0, y / 10) for y in range(-10, 11)]  # the known map: a box at x 3.0..3.2
    crate = [(-1.5, 1.0 + y / 20) for y in range(0, 12)]  # unknown but 0.55 m wide: an obstacle, not an object
    disc = Discovery(DiscoveryConfig(confirm_scans=2), [((3.0, -1.5), (3.2, 1.5))])
    scan = synthetic_scan(can + wall + crate)
    assert disc.update(scan) == []  # seen once: not yet found
    found = disc.update(scan)
    assert len(found) == 1 and len(disc.tracks) == 1
    assert math.dist(found[0].xy, (2.0, 0.0)) < 0.005  # circle fit of the known radius
    assert disc.update(scan) == []  # found (and logged) once only
