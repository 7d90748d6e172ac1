"""What a behaviour leaves its actuators doing when something else stops it: a monitor, or a parallel sibling.

docs/behaviours.md ("Monitors that act"): a monitor with ``action = "recover"`` halts the task, drops the task's
commands of that tick and brings every actuator to a protective stop; the recovery then runs. docs/plugins.md: a
protective stop holds the device where it is. ("Composites"): a ``parallel`` that ends halts the children still
running (their ``halt(t)`` commands are sent). Here the recovery, or the step after the parallel, is a ``record``
that commands nothing, so whatever the stopped behaviour last sent must not go on. The oracle is the world: the
mobile base's speed, the arm's joint angles and tool link, the cube between the fingers (both fingers' contacts,
its height). ``tests/test_prop_halt.py`` covers a ``timeout``'s halt.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomllib
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.testing import make_sim

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
CASES = {  # behaviour type -> (shipped config, a cheap sensor for the record steps)
    "patrol": ("patrol.toml", "bump"),
    "go_to_goal": ("go_to_goal.toml", "scan"),
    "pick_place": ("pick_place.toml", "poses"),
    "sort": ("sort_robot.toml", "truth"),
}


def shipped(name: str) -> tuple[dict[str, Any], dict[str, Any], str]:
    file, sensor = CASES[name]
    cfg = tomllib.loads((CONFIGS / file).read_text(encoding="utf-8"))
    task = cfg.pop("behaviour")
    assert task["type"] == name
    cfg["world"] = {**cfg.get("world", {}), "max_time": 60.0}
    cfg.pop("monitors", None)
    cfg.pop("recoveries", None)
    return cfg, task, sensor


def preempted_config(name: str, seconds: float) -> dict[str, Any]:
    """The shipped task watched by a ``guard`` with ``action = "recover"`` that trips ``seconds`` in: on the first
    contact of a ball dropped far from the robot from the height that takes about that long to fall (h = g t^2 / 2;
    the engine's air damping makes it later). The recovery records for a second and a half and commands nothing."""
    cfg, task, sensor = shipped(name)
    cfg["behaviour"] = task
    height = 0.5 * 9.81 * seconds**2 + 0.05
    cfg["bodies"]["ball"] = {"shape": "sphere", "radius": 0.05, "mass": 0.1, "position": [40.0, 40.0, height]}
    cfg["sensors"]["ball_down"] = {"type": "contact", "body": "ball", "other": "plane"}
    cfg["monitors"] = {"trip": {"type": "guard", "sensor": "ball_down", "action": "recover", "recovery": "pause"}}
    cfg["recoveries"] = {"pause": {"type": "record", "duration": 1.5, "components": [sensor]}}
    return cfg


def sibling_config(name: str, seconds: float) -> dict[str, Any]:
    """The shipped task beside a ``record`` of ``seconds`` in a ``parallel`` that succeeds with one child (the
    record ends first: the task is halted), then a step that records for a second and commands nothing."""
    cfg, task, sensor = shipped(name)
    cfg["behaviour"] = {"type": "sequence", "steps": [
        {"type": "parallel", "success": "one", "children": [
            task, {"type": "record", "name": "clock", "duration": seconds, "components": [sensor]}]},
        {"type": "record", "name": "after", "duration": 1.5, "components": [sensor]}]}
    return cfg


def base_speed(sim: Any) -> float:
    lin, _ = sim.world.velocity(sim.components["drive"].body)
    return math.hypot(lin[0], lin[1])


def arm_joints(sim: Any) -> np.ndarray:
    w, arm = sim.world, sim.components["arm"].body
    return np.array([s[0] for s in w.joint_states(arm, [j.index for j in w.joints(arm) if j.movable])])


def tool(sim: Any) -> np.ndarray:
    w, arm = sim.world, sim.components["arm"]
    link = next(j.index for j in w.joints(arm.body) if j.child_link == arm.config.ee_link)
    return np.array(w.pose(arm.body, link)[0])


def held_by_world(sim: Any) -> list[tuple[str, float]]:
    """Bodies both finger links touch in the world, with their height (m)."""
    w = sim.world
    panda = sim.components["gripper"].body
    sides = []
    for name in ("panda_leftfinger", "panda_rightfinger"):
        index = next(j.index for j in w.joints(panda) if j.child_link == name)
        sides.append({c.other for c in w.contacts(panda, link=index) if c.other != panda})
    return [(w.body_name(b) or str(b), w.pose(b)[0][2]) for b in sorted(sides[0] & sides[1])]


def run_to_stop(sim: Any, kind: str, seconds: float) -> None:
    hz = sim.world.physics_hz
    sim.step(round(seconds * hz) - 2)
    while not [r for r in sim.trace if r["kind"] == kind] and sim.world.tick < (1.5 * seconds + 0.5) * hz:
        sim.step(1)
    assert [r for r in sim.trace if r["kind"] == kind], f"no {kind} by t = {sim.world.time:.2f} s"


def check_left_stopped(sim: Any, name: str) -> list[tuple[str, float]]:
    """From the stop on, 0.5 s to come to rest, then 0.4 s more in which nothing commands the actuators."""
    hz = sim.world.physics_hz
    if name in ("patrol", "go_to_goal"):
        sim.step(round(0.5 * hz))
        before = base_speed(sim)
        sim.step(round(0.4 * hz))
        after = base_speed(sim)
        assert before < 0.03 and after < 0.03, f"{name}: the base still moves at {after:.3f} m/s after the stop"
        return []
    tool_at_stop, held_at_stop = tool(sim), held_by_world(sim)
    sim.step(round(0.5 * hz))
    before = arm_joints(sim)
    sim.step(round(0.4 * hz))
    after = arm_joints(sim)
    assert np.max(np.abs(after - before)) < 0.01, f"{name}: the arm still moves after the stop"
    moved = float(np.linalg.norm(tool(sim) - tool_at_stop))
    assert moved < 0.02, f"{name}: the tool went on {moved:.3f} m after the stop"
    held_now = held_by_world(sim)
    # the gripper keeps what it holds: the same body between both fingers, not dropped (its height kept)
    assert [b for b, _ in held_now] == [b for b, _ in held_at_stop], f"{name}: held {held_at_stop}, now {held_now}"
    for (_, z0), (_, z1) in zip(held_at_stop, held_now, strict=True):
        assert abs(z1 - z0) < 0.02, f"{name}: the held body moved {z1 - z0:+.3f} m in z after the stop"
    return held_at_stop


@pytest.mark.parametrize("name", [  # about 0.3-0.6 s a mobile case: all in the slow tier
    pytest.param("patrol", marks=pytest.mark.slow), pytest.param("go_to_goal", marks=pytest.mark.slow),
    pytest.param("pick_place", marks=pytest.mark.slow), pytest.param("sort", marks=pytest.mark.slow)])
@settings(max_examples=2, deadline=None, derandomize=True)
@given(st.floats(0.3, 1.8))  # pick_place places its cube by 2.3 s
@example(1.2)  # pick_place and sort carry a cube then
def test_a_monitor_that_preempts_leaves_the_actuators_stopped(name: str, seconds: float) -> None:
    with make_sim(preempted_config(name, seconds), base_dir=CONFIGS) as sim:
        run_to_stop(sim, "monitor_preempt", seconds)
        held = check_left_stopped(sim, name)
        assert held or seconds != 1.2 or name not in ("pick_place", "sort"), "the example stops a carry"
        assert sim.outcome is None or sim.outcome.status != "error"


@pytest.mark.parametrize("name", [
    pytest.param("patrol", marks=pytest.mark.slow),
    pytest.param("pick_place", marks=pytest.mark.slow), pytest.param("sort", marks=pytest.mark.slow)])
@settings(max_examples=2, deadline=None, derandomize=True)
@given(st.floats(0.3, 1.8))  # pick_place places its cube by 2.3 s
@example(1.2)  # pick_place and sort carry a cube then
def test_a_parallel_sibling_that_ends_first_leaves_the_actuators_stopped(name: str, seconds: float) -> None:
    with make_sim(sibling_config(name, seconds), base_dir=CONFIGS) as sim:
        run_to_stop(sim, "child_halt", seconds)
        held = check_left_stopped(sim, name)
        assert held or seconds != 1.2 or name not in ("pick_place", "sort"), "the example stops a carry"
        assert sim.outcome is None or sim.outcome.status != "error"


DIFFBOT = {"bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
           "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
           "actuators": {"drive": {"type": "diff_drive"}}}


@settings(max_examples=3, deadline=None, derandomize=True)  # about 0.1 s an example
@given(st.floats(-0.4, 0.4), st.floats(-2.0, 2.0), st.integers(20, 120))
def test_a_drives_protective_stop_stops_its_wheels_until_the_next_command(v: float, omega: float,
                                                                          ticks: int) -> None:
    """``diff_drive``'s protective stop: recorded in the trace; the wheels (the world's joint speeds) and the base
    come to rest and stay there with no command; the next command drives again."""
    from robokit.msgs.mobile import Twist

    with make_sim(DIFFBOT) as sim:
        w, drive = sim.world, sim.components["drive"]
        drive.command(Twist(v, omega))
        sim.step(ticks)
        before = len(sim.trace)
        drive.protective_stop("a test")
        assert [(r["kind"], r["actuator"], r["reason"]) for r in sim.trace[before:]] == [
            ("protective_stop", "drive", "a test")]
        sim.step(round(0.5 * w.physics_hz))
        wheels = [j.index for j in w.joints(drive.body) if j.name in ("left_wheel", "right_wheel")]
        for _ in range(3):
            sim.step(round(0.2 * w.physics_hz))
            speeds = [abs(s[1]) for s in w.joint_states(drive.body, wheels)]
            lin, ang = w.velocity(drive.body)
            assert max(speeds) < 0.3, f"the wheels still turn at {max(speeds):.3f} rad/s"
            assert math.hypot(lin[0], lin[1]) < 0.01 and abs(ang[2]) < 0.05
        drive.command(Twist(0.2, 0.0))
        sim.step(round(0.5 * w.physics_hz))
        assert math.hypot(*w.velocity(drive.body)[0][:2]) > 0.1, "a new command drives again"


def test_a_fresh_drive_stands_still_until_commanded() -> None:
    """Built and never commanded: the wheels and the base do not move (the world), and the reading says so: the
    stop command, zero wheel speeds, no distance, touching nothing but the ground."""
    from robokit.msgs.mobile import STOP

    with make_sim(DIFFBOT) as sim:
        w, drive = sim.world, sim.components["drive"]
        start = w.pose(drive.body)[0]
        sim.step(round(1.0 * w.physics_hz))
        wheels = [j.index for j in w.joints(drive.body) if j.name in ("left_wheel", "right_wheel")]
        assert max(abs(s[1]) for s in w.joint_states(drive.body, wheels)) < 0.05
        assert math.dist(w.pose(drive.body)[0][:2], start[:2]) < 1e-3
        r = sim.readings["drive"]
        assert r.command == STOP and r.distance < 1e-3 and r.contacts == ()
        assert max(abs(v) for v in r.wheel_speeds) < 0.05
