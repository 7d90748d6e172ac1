"""go_to_goal and the lidar avoider: open field, lesson 07's three boxes, a concave U trap; the pure helpers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from robokit_behaviours.avoidance import AvoidanceConfig, clearances, track_heading

from robokit.testing import PLANE, make_sim, states_visited

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def run_to_end(sim, max_s: float) -> set[str]:
    """Step until the behaviour ends; return every body the robot touched."""
    touched: set[str] = set()
    while sim.outcome is None and sim.world.time < max_s:
        sim.step(12)
        touched |= set(sim.readings["drive"].contacts)
    return touched


def test_clearances_and_heading_control() -> None:
    wall = np.array([[1.0, y] for y in np.linspace(-1, 1, 41)])  # a wall 1 m ahead, robot frame
    clear = clearances(wall, np.array([0.0, math.pi / 2, math.pi]), corridor=0.25, far=9.0)
    assert clear[0] == pytest.approx(0.75, abs=0.01)  # the robot disk (r = 0.25) touches it after 0.75 m
    assert clear[1] == 9.0 and clear[2] == 9.0  # sideways and backwards are free
    cfg = AvoidanceConfig()
    turn = track_heading(math.radians(120), 2.0, 9.0, cfg)
    assert turn.v == 0.0 and turn.omega == cfg.max_turn_rate  # turn in place first
    go = track_heading(0.1, 2.0, 9.0, cfg)
    assert 0.9 * cfg.max_speed < go.v <= cfg.max_speed and 0 < go.omega < cfg.max_turn_rate  # smooth, no bang-bang
    assert track_heading(0.0, 2.0, 0.02, cfg).v == 0.0  # blocked straight ahead: stop


def test_go_to_goal_reaches_the_goal_within_tolerance() -> None:
    cfg = {
        "bodies": {"plane": PLANE},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06], "rpy_deg": [0, 0, 180]}},
        "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
        "behaviour": {"type": "go_to_goal", "rate_hz": 20, "goal": [2.0, 1.0], "tolerance": 0.1, "scan": ""},
    }
    with make_sim(cfg) as sim:
        run_to_end(sim, 30)
        x, y, _ = sim.readings["drive"].pose
        assert sim.outcome.status == "succeeded"
        assert math.hypot(x - 2.0, y - 1.0) <= 0.1
        assert states_visited(sim)[:2] == ["DRIVING", "ARRIVED"]  # turned in place first, then drove


def test_avoidance_gets_around_lesson_07_boxes() -> None:
    with make_sim(CONFIGS / "go_to_goal.toml") as sim:
        touched = run_to_end(sim, 60)
        assert sim.outcome.status == "succeeded", sim.outcome
        assert touched == set()  # never touched a box
        assert "AVOIDING" in states_visited(sim)


U_TRAP = {
    "bodies": {
        "plane": PLANE,
        # a U open towards -x; the goal is behind its closed end
        "u_back": {"shape": "box", "size": [0.1, 2.1, 0.4], "mass": 0, "position": [2.0, 0, 0.2]},
        "u_top": {"shape": "box", "size": [1.6, 0.1, 0.4], "mass": 0, "position": [1.25, 1.0, 0.2]},
        "u_bot": {"shape": "box", "size": [1.6, 0.1, 0.4], "mass": 0, "position": [1.25, -1.0, 0.2]},
    },
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [1.0, 0.3, 0.06]}},
    "sensors": {"scan": {"type": "lidar", "rate_hz": 10}},
    "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
    "behaviour": {"type": "go_to_goal", "rate_hz": 20, "goal": [4.0, 0.3], "timeout": 60},
}


def test_avoidance_escapes_a_concave_trap() -> None:
    with make_sim(U_TRAP) as sim:
        touched = run_to_end(sim, 60)
        assert sim.outcome.status == "succeeded", sim.outcome
        assert touched == set()
        assert sim.behaviour.result()["distance_travelled"] > 4.0  # it went out of the U and round it


def test_husky_goes_round_a_crate_by_config() -> None:
    with make_sim(CONFIGS / "husky_go_to_goal.toml") as sim:
        touched = run_to_end(sim, 50)
        assert sim.outcome.status == "succeeded", sim.outcome
        assert touched == set() and "AVOIDING" in states_visited(sim)
