"""diff_drive's frames over generated start poses and drives: pose, speed, odometry and distance against the world.

The diffbot starts at a random place and heading, the drive is reset there (odometry starts at the true pose), and a
generated sequence of (v, omega) commands is driven. The oracle is the world, read every tick in the test: the
base's link frame (heading from its rotation matrix's x axis), its velocity projected on that heading, the path
length summed tick by tick. Odometry, integrated from wheel angles alone, must stay near the true pose (the diffbot
barely slips at these speeds); a sign or frame error puts it metres or radians away.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.msgs.mobile import Twist
from robokit.testing import PLANE, make_sim

SCENE = {"bodies": {"plane": PLANE}, "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
         "actuators": {"drive": {"type": "diff_drive"}}}


@pytest.fixture(scope="module")
def sim() -> Iterator[Any]:
    with make_sim(SCENE) as s:
        yield s


def heading(world: Any, body: int) -> tuple[np.ndarray, float]:
    """Base position and heading (rad): where the base's +x axis points, seen from above."""
    pos, orn = world.pose(body)
    x, y, z, w = orn
    forward = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w)])  # R @ (1, 0, 0)
    return np.asarray(pos, float), math.atan2(forward[1], forward[0])


def angle_diff(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2 * math.pi))


segments = st.lists(st.tuples(st.floats(-0.3, 0.3), st.floats(-1.2, 1.2), st.integers(48, 240)), min_size=1,
                    max_size=3)


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.floats(-2, 2), st.floats(-2, 2), st.floats(-math.pi, math.pi), segments)
def test_drive_reading_and_odometry_follow_the_world(sim: Any, x: float, y: float, yaw: float,
                                                     drives: list[tuple[float, float, int]]) -> None:
    w, drive = sim.world, sim.components["drive"]
    robot = w.body("robot")
    w.set_pose(robot, [x, y, 0.06], [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    drive.reset()
    start = drive.read()
    assert np.allclose(start.odometry, start.pose, atol=1e-9)  # odometry starts at the true pose
    pos, head = heading(w, robot)
    assert np.allclose(start.pose[:2], [x, y], atol=1e-4) and angle_diff(start.pose[2], yaw) < 1e-4
    path = 0.0
    for v, omega, ticks in drives:
        drive.command(Twist(v, omega))
        for _ in range(ticks):
            before = pos
            sim.step(1)
            pos, head = heading(w, robot)
            path += float(np.hypot(*(pos[:2] - before[:2])))
    state = drive.read()
    assert np.allclose(state.pose[:2], pos[:2], atol=1e-6) and angle_diff(state.pose[2], head) < 1e-6
    lin, ang = w.velocity(robot)
    assert state.v == pytest.approx(lin[0] * math.cos(head) + lin[1] * math.sin(head), abs=1e-6)
    assert state.omega == pytest.approx(ang[2], abs=1e-6)
    assert state.distance == pytest.approx(path, rel=0.02, abs=2e-3)
    # wheel odometry near the truth: a few centimetres and degrees over at most 3 s of driving
    odo_x, odo_y, odo_yaw = state.odometry
    assert math.hypot(odo_x - pos[0], odo_y - pos[1]) < 0.03 + 0.05 * path
    assert angle_diff(odo_yaw, head) < 0.05 + 0.05 * sum(abs(o) * t / 240 for _, o, t in drives)
    drive.command(Twist(0.0, 0.0))
    sim.step(120)  # leave it standing for the next example


@settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.floats(-math.pi, math.pi), st.floats(0.1, 0.3))
def test_forward_is_along_the_heading_and_left_turns_are_counter_clockwise(sim: Any, yaw: float, v: float) -> None:
    w, drive = sim.world, sim.components["drive"]
    robot = w.body("robot")
    w.set_pose(robot, [0.0, 0.0, 0.06], [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    drive.reset()
    drive.command(Twist(v, 0.0))
    sim.step(240)
    pos, head = heading(w, robot)
    assert pos[0] * math.cos(yaw) + pos[1] * math.sin(yaw) > 0.5 * v  # went forward along its start heading
    assert abs(-pos[0] * math.sin(yaw) + pos[1] * math.cos(yaw)) < 0.02  # not sideways
    drive.command(Twist(0.0, 1.0))  # omega > 0: counter-clockwise seen from above (REP 103)
    sim.step(120)
    _, turned = heading(w, robot)
    assert 0.2 < math.remainder(turned - head, 2 * math.pi) < 1.0
    drive.command(Twist(0.0, 0.0))
    sim.step(120)
