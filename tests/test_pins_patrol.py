"""patrol's bookkeeping, counted by hand: laps and waypoints of each visit, one collision per new contact with a map
body (never with a loose object), waypoint_timeout per leg, waypoints too near an obstacle refused."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from robokit.errors import ConfigError
from robokit.testing import PLANE, make_sim


def room(behaviour: dict, box: bool = True) -> dict:
    def wall(x: float, y: float, sx: float, sy: float) -> dict:
        return {"shape": "box", "size": [sx, sy, 0.4], "mass": 0, "position": [x, y, 0.2]}

    bodies = {"plane": PLANE, "wall_s": wall(1.5, -1.55, 5.2, 0.1), "wall_n": wall(1.5, 2.55, 5.2, 0.1),
              "wall_w": wall(-1.05, 0.5, 0.1, 4.2), "wall_e": wall(4.05, 0.5, 0.1, 4.2),
              "can": {"shape": "cylinder", "radius": 0.05, "height": 0.2, "mass": 0.2, "position": [3.5, 2.0, 0.1]}}
    if box:
        bodies["box"] = {"shape": "box", "size": [0.8, 0.8, 0.5], "mass": 0, "position": [1.5, 0.5, 0.25]}
    return {"world": {"max_time": 60},
            "bodies": bodies,
            "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
            "sensors": {"scan": {"type": "lidar", "rate_hz": 10}, "bump": {"type": "contact", "body": "robot"}},
            "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
            "behaviour": {"type": "patrol", "rate_hz": 20, "contact_sensor": "bump", **behaviour}}


def test_collisions_count_each_new_contact_with_a_map_body_once() -> None:
    """Scripted contact readings: box for 5 ticks, nothing, box again, the can (not part of the map) throughout."""
    with make_sim(room({"waypoints": [[3.0, -0.8]]})) as sim:
        patrol = sim.behaviour
        script = [("box", "can")] * 5 + [("can",)] + [("can", "box", "wall_n")] * 3
        for k, others in enumerate(script):
            patrol.count_collisions({"bump": SimpleNamespace(others=others)}, k * 0.05)
        assert [(c["body"], c["t"]) for c in patrol.collisions] == [("box", 0.0), ("box", 0.3), ("wall_n", 0.3)]
        assert patrol.result()["collisions"] == 3


def test_visits_record_waypoint_and_lap_and_the_patrol_ends_after_the_last_leg() -> None:
    with make_sim(room({"waypoints": [[3.0, -0.8], [3.0, 1.8], [0.0, 1.8]], "laps": 2})) as sim:
        patrol = sim.behaviour
        for leg in range(6):
            assert patrol.outcome is None
            patrol.next_leg(10.0 * (leg + 1), reached=leg != 4)
        assert patrol.outcome is not None and patrol.outcome.status == "failed"  # one visit was missed
        visits = [(v["waypoint"], v["lap"]) for v in patrol.reached]
        assert visits == [(0, 0), (1, 0), (2, 0), (0, 1), (2, 1)]
        assert [(m["waypoint"], m["lap"]) for m in patrol.missed] == [(1, 1)]
        r = patrol.result()
        assert (r["waypoints_total"], r["waypoints_reached"], r["waypoints_missed"]) == (6, 5, 1)


def test_waypoint_timeout_counts_per_leg() -> None:
    """Three legs of ~1-1.5 m, each well within 12 s, the whole patrol longer than 12 s: all reached."""
    cfg = room({"waypoints": [[1.2, 0.0], [1.2, 1.2], [0.0, 1.2], [0.0, 0.0]], "waypoint_timeout": 12.0}, box=False)
    with make_sim(cfg) as sim:
        result = sim.run()
    assert result.outcome == "succeeded", result.reason
    assert result.result["sim_time"] > 12.0  # so a timeout counted from the start would have cut the last leg
    assert result.result["waypoints_missed"] == 0


def test_a_waypoint_within_robot_radius_of_an_obstacle_is_refused() -> None:
    """The box spans x 1.1..1.9: (0.95, 0.5) is 0.15 m from it, inside robot_radius 0.2."""
    with pytest.raises(ConfigError, match=r"waypoints\[1\].*inside obstacle 'box'"):
        make_sim(room({"waypoints": [[3.0, -0.8], [0.95, 0.5]]}))
    with make_sim(room({"waypoints": [[3.0, -0.8], [0.85, 0.5]]})) as sim:  # 0.25 m away: fine
        assert sim.behaviour.map
