"""go_to_goal with ``planner = "astar"`` on seeded scenes, judged by the world: the robot ends within the tolerance
of the goal and never touches a wall (drive contacts read at every drive update). The slow tier runs every kind of
scene over several seeds and shows the clearance rules failing where the planner succeeds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from robokit.errors import UserError
from robokit.planning import DwaConfig
from robokit.planning.scenes import KINDS, scene
from robokit.testing import make_sim


def drive_to_end(cfg: dict[str, Any], max_s: float, commands: list[Any] | None = None
                 ) -> tuple[str | None, float, set[str], dict[str, Any]]:
    """Run until the behaviour ends; the outcome, the final distance to the goal, every body touched, result.
    ``commands`` collects the drive's command at every drive update."""
    touched: set[str] = set()
    with make_sim(cfg) as sim:
        while sim.outcome is None and sim.world.time < max_s:
            sim.step(4)  # the drive reads contacts every 4 physics ticks (60 Hz)
            touched |= set(sim.readings["drive"].contacts)
            if commands is not None:
                commands.append(sim.readings["drive"].command)
        x, y, _ = sim.readings["drive"].pose
        gx, gy = cfg["behaviour"]["goal"]
        status = sim.outcome.status if sim.outcome else None
        return status, math.hypot(gx - x, gy - y), touched, sim.behaviour.result()


@pytest.mark.slow
def test_planner_reaches_the_goal_without_touching_a_wall() -> None:
    cfg, _ = scene("dead_end", 0, planner="astar", timeout=40)
    commands: list[Any] = []
    status, left, touched, result = drive_to_end(cfg, 40, commands)
    assert status == "succeeded" and left <= 0.2
    assert touched == set()
    assert result["planning"]["found"] == result["planning"]["plans"] >= 1
    dwa = DwaConfig()  # the speeds change by no more than the limits allow in one behaviour step (20 Hz)
    moving = commands[:-1]  # the last one is the stop on arrival
    pairs = list(zip(moving, moving[1:], strict=False))
    assert max(abs(b.v - a.v) for a, b in pairs) <= dwa.max_accel / 20 + 1e-9
    assert max(abs(b.omega - a.omega) for a, b in pairs) <= dwa.max_yaw_accel / 20 + 1e-9
    assert max(c.v for c in commands) <= dwa.max_speed and max(abs(c.omega) for c in commands) <= dwa.max_turn_rate


def test_known_map_without_a_lidar() -> None:
    cfg, _ = scene("narrow", 0, planner="astar", timeout=40)
    cfg["behaviour"].update(scan="", planning={"known_map": True})
    del cfg["sensors"]
    status, left, touched, _ = drive_to_end(cfg, 40)
    assert status == "succeeded" and left <= 0.2 and touched == set()


def test_astar_without_lidar_or_map_is_refused() -> None:
    cfg, _ = scene("open", 0, planner="astar")
    cfg["behaviour"]["scan"] = ""
    del cfg["sensors"]
    with pytest.raises(UserError, match="needs a lidar"):
        make_sim(cfg)


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", range(4))
def test_planner_on_every_scene(kind: str, seed: int) -> None:
    cfg, _ = scene(kind, seed, planner="astar", timeout=60)
    status, left, touched, _ = drive_to_end(cfg, 60)
    assert status == "succeeded" and left <= 0.2 and touched == set()


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["dead_end", "narrow"])
def test_rules_fail_where_the_planner_succeeds(kind: str) -> None:
    cfg, _ = scene(kind, 0, planner="rules", timeout=60)
    status, left, _, _ = drive_to_end(cfg, 61)
    assert status == "failed" and left > 1.0


@pytest.mark.slow
def test_patrol_and_collect_with_the_planner() -> None:
    """Lesson 07's patrol and project B's patrol-and-collect, planner on: every waypoint, no collision, every can."""
    root = Path(__file__).resolve().parents[1] / "configs"
    with make_sim(root / "patrol.toml", overrides={"behaviour.planner": "astar"}) as sim:
        sim.run()
        r = sim.behaviour.result()
        assert sim.outcome.status == "succeeded"
        assert r["waypoints_reached"] == r["waypoints_total"] == 6 and r["collisions"] == 0
    with make_sim(root / "patrol_robot.toml", overrides={"behaviour.planner": "astar"}) as sim:
        sim.run()
        r = sim.behaviour.result()
        assert sim.outcome.status == "succeeded" and r["collisions"] == 0
        assert r["objects_collected"] == len(sim.components["truth"].names)
