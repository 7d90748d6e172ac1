"""``ik_arm``'s tool frame (``ee_offset``, ``ee_rpy_deg``) and its protective stop, judged by the world.

The config reference promises that with a tool frame "targets and readings are poses of this frame": the frame at
``ee_offset`` in the end-effector link's frame, turned by ``ee_rpy_deg`` (roll, pitch, yaw about the link's fixed
axes). The tool here is turned by a rotation that is not its own inverse (10, -25, 40 degrees), so a tool frame
applied the wrong way round, or its inverse applied where the frame belongs, lands elsewhere. The oracle: the
world's pose of the link composed with the tool as 4x4 matrices, rotations built from axis and angle (Rodrigues).

A protective stop "holds the measured joint positions with zero target velocity, drops the path": stopped at a
generated moment of a move, the arm's joints stay where they were at that tick (the world's joint states), its
reading says ``failed`` and ``stopped``, and the move never resumes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import rodrigues, rotation

from robokit.msgs.arm import MoveTo
from robokit.testing import make_sim

X, Y, Z = np.eye(3)
OFFSET = np.array([0.015, -0.02, 0.09])
RPY = (10.0, -25.0, 40.0)
READY = {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8, "panda_joint7": 0.785}
SCENE = {
    "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {"arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_hand",
                          "ee_offset": OFFSET.tolist(), "ee_rpy_deg": list(RPY), "ready_pose": READY}},
}
PROPS = settings(max_examples=5, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Roll about fixed x, then pitch about fixed y, then yaw about fixed z."""
    return rodrigues(Z, yaw) @ rodrigues(Y, pitch) @ rodrigues(X, roll)


TOOL = rpy_matrix(*np.radians(RPY))


def axis_angle_quaternion(axis: np.ndarray, angle: float) -> tuple[float, float, float, float]:
    k = np.asarray(axis, float) / np.linalg.norm(axis) * math.sin(angle / 2.0)
    return (float(k[0]), float(k[1]), float(k[2]), math.cos(angle / 2.0))


def hamilton(a: tuple, b: tuple) -> tuple[float, float, float, float]:
    """The product ``a b`` of two ``(x, y, z, w)`` quaternions (``b`` first, then ``a``)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, (np.trace(a.T @ b) - 1.0) / 2.0)))


def tool_pose(sim) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """The tool frame in the world: the world's hand link frame times the tool, as matrices."""
    w = sim.world
    panda = w.body("panda")
    pos, orn = w.pose(panda, w.link(panda, "panda_hand"))
    r = rotation(orn)
    return np.asarray(pos) + r @ OFFSET, r @ TOOL


def arm_angles(sim) -> np.ndarray:  # type: ignore[no-untyped-def]
    w = sim.world
    panda = w.body("panda")
    idx = [w.joint(panda, f"panda_joint{i}").index for i in range(1, 8)]
    return np.array([s[0] for s in w.joint_states(panda, idx)])


@pytest.fixture(scope="module")
def sim() -> Iterator:
    with make_sim(SCENE) as s:
        yield s


@pytest.fixture
def fresh_sim() -> Iterator:
    """A world of its own: where the arm starts must not depend on which tests ran before (random order)."""
    with make_sim(SCENE) as s:
        yield s


@PROPS
@given(st.lists(st.floats(-0.5, 0.5), min_size=7, max_size=7))
def test_the_reading_is_the_tool_frame_at_any_joint_angles(sim, deltas: list[float]) -> None:
    w = sim.world
    panda = w.body("panda")
    start = arm_angles(sim)
    for i, d in enumerate(deltas, start=1):
        w.reset_joint(panda, w.joint(panda, f"panda_joint{i}").index, float(start[i - 1] + d))
    try:
        pos, rot = tool_pose(sim)
        state = sim.components["arm"].read()
        assert np.allclose(state.position, pos, atol=1e-6)
        assert math.degrees(angle_between(rotation(state.orientation), rot)) < 1e-3
    finally:
        for i, q in enumerate(start, start=1):
            w.reset_joint(panda, w.joint(panda, f"panda_joint{i}").index, float(q))


@PROPS
@given(st.floats(0.35, 0.55), st.floats(-0.2, 0.2), st.floats(0.25, 0.45),
       st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(lambda v: np.linalg.norm(v) > 0.1),
       st.floats(-0.35, 0.35))
def test_a_target_pose_is_where_the_tool_frame_ends(fresh_sim, x: float, y: float, z: float, axis: tuple,
                                                   angle: float) -> None:
    """The tool pointing down (its +z along world -z), turned up to 20 degrees about a random axis."""
    sim = fresh_sim
    want = rodrigues(np.array(axis), angle) @ rodrigues(X, math.pi)
    arm = sim.components["arm"]
    arm.command(MoveTo((x, y, z), orientation=hamilton(axis_angle_quaternion(np.array(axis), angle),
                                                        axis_angle_quaternion(X, math.pi))))
    for _ in range(8):
        sim.step(120)
        state = sim.readings["arm"]
        if state.status != "moving":
            break
    assert state.status == "reached", state.reason
    pos, rot = tool_pose(sim)
    assert np.allclose(pos, [x, y, z], atol=0.006)
    assert math.degrees(angle_between(rot, want)) < 3.0
    assert np.allclose(state.target_position, [x, y, z])
    assert math.degrees(angle_between(rotation(state.target_orientation), want)) < 1e-3


@PROPS
@given(st.integers(6, 30), st.floats(-0.05, 0.05), st.floats(-0.05, 0.05))
def test_a_protective_stop_holds_the_arm_where_it_was_stopped(sim, stop_after: int, dx: float, dy: float) -> None:
    arm = sim.components["arm"]
    start, _ = tool_pose(sim)
    goals = [np.array([0.45 + dx, 0.2 + dy, 0.25]), np.array([0.45 - dx, -0.2 - dy, 0.45])]
    goal = max(goals, key=lambda g: float(np.linalg.norm(g - start)))  # a move of 0.2 m or more
    arm.command(MoveTo(tuple(goal.tolist())))
    sim.step(stop_after)
    assert sim.readings["arm"].status == "moving"
    at_stop, tool_at_stop = arm_angles(sim), tool_pose(sim)[0]
    arm.protective_stop("a test")
    sim.step(120)
    state = sim.readings["arm"]
    assert (state.status, state.stopped) == ("failed", True)
    assert state.reason == "protective stop: a test"
    # held where it was stopped: the joints move no further than they brake in a few ticks, the tool stays within
    # a centimetre of where it was, far from the goal it was heading for
    assert np.max(np.abs(arm_angles(sim) - at_stop)) < 0.05
    assert np.linalg.norm(tool_pose(sim)[0] - tool_at_stop) < 0.01
    assert np.linalg.norm(tool_pose(sim)[0] - goal) > 0.1
    held = arm_angles(sim)
    sim.step(60)
    assert np.max(np.abs(arm_angles(sim) - held)) < 1e-3  # and stays there


def _quat(axis: Any, angle: float) -> tuple[float, float, float, float]:
    """The ``(x, y, z, w)`` quaternion of a rotation by ``angle`` about ``axis``, from its definition."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    s = math.sin(angle / 2.0)
    return (k[0] * s, k[1] * s, k[2] * s, math.cos(angle / 2.0))


def _hamilton(a: Any, b: Any) -> tuple[float, float, float, float]:
    """The Hamilton product ``a b`` of two ``(x, y, z, w)`` quaternions, written out."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


axes = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.1)
angles = st.one_of(st.floats(0.0, math.pi - 1e-3), st.floats(1e-9, 1e-4))  # small ones: precision near zero


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(axes, angles, axes, st.floats(0.0, math.pi), st.booleans())
def test_the_orientation_error_is_the_rotation_vector_from_the_frame_to_its_target(
        axis: Any, angle: float, from_axis: Any, from_angle: float, flip: bool) -> None:
    """The IK arm steers its orientation by the rotation vector taking the tool's frame to the target's, in world
    axes (the error its numpy solve drives to zero): here the target is made by turning a frame by a known rotation
    vector, either sign of its quaternion (the same rotation), and that vector must come back, also for angles near
    zero; the matrices of both frames (a second computation) agree with it."""
    from robokit_plugins.ik_arm import _rotvec

    current = _quat(from_axis, from_angle)
    target = _hamilton(_quat(axis, angle), current)  # turned in world axes: the turn's quaternion on the left
    if flip:
        target = tuple(-v for v in target)
    want = np.asarray(axis, float) / np.linalg.norm(axis) * angle
    got = _rotvec(current, target)
    assert np.allclose(got, want, rtol=1e-6, atol=1e-9)
    assert np.allclose(rodrigues(got, float(np.linalg.norm(got))) @ rotation(current) if np.linalg.norm(got) > 0
                       else rotation(current), rotation(target), atol=1e-9)
