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
from hypothesis import HealthCheck, example, given, settings
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
    before = len(sim.trace)
    arm.protective_stop("a test")
    assert [(r["kind"], r["actuator"], r["reason"]) for r in sim.trace[before:]] == [
        ("protective_stop", "arm", "a test")]
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


# ------------------------------------------------------------------------ the Jacobian, the numpy solve, holds
def set_arm(sim: Any, q: np.ndarray) -> None:
    w = sim.world
    panda = w.body("panda")
    for i, v in enumerate(q, start=1):
        w.reset_joint(panda, w.joint(panda, f"panda_joint{i}").index, float(v), 0.0)


def rotvec(r: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation matrix (axis times angle), angles below pi; the angle from atan2 of the
    skew part's length and the trace (acos of the trace alone loses the small angles of a finite difference)."""
    vee = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    sin = float(np.linalg.norm(vee)) / 2.0
    if sin < 1e-15:
        return np.zeros(3)
    angle = math.atan2(sin, (np.trace(r) - 1.0) / 2.0)
    return angle / (2.0 * sin) * vee


joint_angles = st.lists(st.floats(-1.0, 1.0), min_size=7, max_size=7)


@PROPS
@given(joint_angles)
def test_the_jacobian_is_the_world_tool_frames_derivative(sim, deltas: list[float]) -> None:
    """Each column of the arm's Jacobian (linear rows first) is how the tool frame in the world moves and turns
    when that one joint turns a little: central differences of the world's poses at random joint angles (every
    rotation of the hand, not only a few). The frame it returns is the world's tool frame."""
    arm = sim.components["arm"]
    before = arm_angles(sim)
    q = np.array(arm.ready[arm.arm_cols]) + np.array(deltas)  # not where an earlier test left the arm
    q_all = arm._measured_all()
    q_all[arm.arm_cols] = q
    try:
        jac, tip, orn = arm.chain.jacobian(q_all)
        set_arm(sim, q)
        pos0, rot0 = tool_pose(sim)
        assert np.allclose(tip, pos0, atol=1e-6) and angle_between(rotation(orn), rot0) < 1e-6
        h = 1e-3  # central differences: an error of order h^2; the world's poses carry rounding of order 1e-7
        for k in range(7):
            step = np.zeros(7)
            step[k] = h
            set_arm(sim, q + step)
            p_plus, r_plus = tool_pose(sim)
            set_arm(sim, q - step)
            p_minus, r_minus = tool_pose(sim)
            col = arm.arm_cols[k]
            assert np.allclose(jac[:3, col], (p_plus - p_minus) / (2 * h), atol=2e-3), f"joint {k + 1}: linear"
            assert np.allclose(jac[3:, col], rotvec(r_plus @ r_minus.T) / (2 * h), atol=2e-3), f"joint {k + 1}"
    finally:
        set_arm(sim, before)


@PROPS
@given(joint_angles, st.lists(st.floats(-0.4, 0.4), min_size=7, max_size=7))
@example([0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -0.3, 0.0, 0.0, 0.0])  # the elbow at its lower limit
def test_the_numpy_solve_puts_the_tool_on_the_target_within_the_limits(sim, goal: list[float],
                                                                        start: list[float]) -> None:
    """The damped least-squares solve (the fallback when the engine's IK misses): a target made by the world's
    forward kinematics of random joint angles (a reachable pose in a random orientation), solved from angles up to
    0.4 rad away. The world, put at the answer, has the tool frame on the target within the solve's residuals
    (which it reports), those within ``ik_tolerance`` and four times it in radians; every joint within its limits."""
    arm = sim.components["arm"]
    before = arm_angles(sim)
    w = sim.world
    panda = w.body("panda")
    lo = np.array([w.joint(panda, f"panda_joint{i}").lower for i in range(1, 8)])
    hi = np.array([w.joint(panda, f"panda_joint{i}").upper for i in range(1, 8)])
    q_goal = np.clip(np.array(arm.ready[arm.arm_cols]) + np.array(goal), lo + 1e-3, hi - 1e-3)
    try:
        set_arm(sim, q_goal)
        pos, rot = tool_pose(sim)
        orn = tuple(float(v) for v in np.array(w.pose(panda, w.link(panda, "panda_hand"))[1]))
        target = hamilton(orn, axis_angle_quaternion(*_axis_angle(TOOL)))
        assert angle_between(rotation(target), rot) < 1e-6
        q_all = arm._measured_all()
        q_all[arm.arm_cols] = np.clip(q_goal + np.array(start), lo, hi)
        q, ep, eo = arm._solve_numpy(q_all, pos, target)
        answer = q[arm.arm_cols]
        assert np.all(answer >= lo - 1e-9) and np.all(answer <= hi + 1e-9)
        set_arm(sim, answer)
        got_pos, got_rot = tool_pose(sim)
        assert np.linalg.norm(got_pos - pos) == pytest.approx(ep, abs=1e-6)
        assert angle_between(got_rot, rot) == pytest.approx(eo, abs=1e-5)
        tol = arm.config.ik_tolerance
        assert ep < tol and eo < 4 * tol, f"residual {ep * 1000:.2f} mm, {math.degrees(eo):.3f} deg"
    finally:
        set_arm(sim, before)


def _axis_angle(r: np.ndarray) -> tuple[np.ndarray, float]:
    v = rotvec(r)
    return v / np.linalg.norm(v), float(np.linalg.norm(v))


@PROPS
@given(st.integers(6, 30), st.floats(-0.05, 0.05))
def test_a_hold_mid_move_keeps_the_arm_where_it_is(fresh_sim, hold_after: int, dy: float) -> None:
    """``HoldArm`` (what a halted pick_place or sort sends): the path is dropped and the arm holds the joint
    positions it had, judged by the world's joints and tool frame, far from the goal it was heading for."""
    from robokit.msgs.arm import HoldArm

    sim = fresh_sim
    arm = sim.components["arm"]
    start = tool_pose(sim)[0]
    goal = start + np.array([0.0, 0.25 + dy, -0.1])
    arm.command(MoveTo(tuple(goal.tolist())))
    sim.step(hold_after)
    assert sim.readings["arm"].status == "moving"
    at_hold, tool_at_hold = arm_angles(sim), tool_pose(sim)[0]
    arm.command(HoldArm())
    sim.step(120)
    assert np.max(np.abs(arm_angles(sim) - at_hold)) < 0.05
    assert np.linalg.norm(tool_pose(sim)[0] - tool_at_hold) < 0.01
    assert np.linalg.norm(tool_pose(sim)[0] - goal) > 0.1
    held = arm_angles(sim)
    sim.step(60)
    assert np.max(np.abs(arm_angles(sim) - held)) < 1e-3


@PROPS
@given(joint_angles, st.floats(0.0, 0.04))
def test_a_chain_through_a_sliding_joint_has_the_worlds_derivative(sim, deltas: list[float], slide: float) -> None:
    """A chain that ends in a prismatic joint (the Panda's left finger): its Jacobian's column for the slide moves
    the frame along the joint's axis and turns it not at all; every column matches the world's central differences."""
    from robokit_plugins.kinematics import Chain

    w = sim.world
    panda = w.body("panda")
    joints = [w.joint(panda, f"panda_joint{i}").index for i in range(1, 8)] + [
        w.joint(panda, "panda_finger_joint1").index]
    finger = w.link(panda, "panda_leftfinger")
    chain = Chain(w, panda, finger, {j: k for k, j in enumerate(joints)})
    before = [s[0] for s in w.joint_states(panda, joints)]
    q = np.array([*sim.components["arm"].ready[sim.components["arm"].arm_cols], 0.0]) + np.array([*deltas, 0.0])
    q[7] = slide

    def put(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        for j, v in zip(joints, values, strict=True):
            w.reset_joint(panda, j, float(v), 0.0)
        pos, orn = w.pose(panda, finger)
        return np.asarray(pos), rotation(orn)

    try:
        jac, tip, _ = chain.jacobian(q)
        assert np.allclose(tip, put(q)[0], atol=1e-6)
        h = 1e-3
        for k in range(8):
            step = np.zeros(8)
            step[k] = h
            p_plus, r_plus = put(q + step)
            p_minus, r_minus = put(q - step)
            assert np.allclose(jac[:3, k], (p_plus - p_minus) / (2 * h), atol=2e-3), k
            assert np.allclose(jac[3:, k], rotvec(r_plus @ r_minus.T) / (2 * h), atol=2e-3), k
    finally:
        put(np.array(before))


def test_stop_on_stops_the_arm_at_its_first_contact_for_good() -> None:
    """``stop_on``: the tool driven into a static cube stops in the tick its contact sensor first reports the
    contact (the trace names the cube, the force and the sensor); the arm then ignores every new move."""
    scene = {**SCENE, "world": {"gravity": [0, 0, 0]},
             "bodies": {"cube": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0.0, "position": [3, 3, 3]}},
             "sensors": {"touch": {"type": "contact", "body": "panda", "other": "cube"}},
             "actuators": {"arm": {**SCENE["actuators"]["arm"], "stop_on": "touch"}}}
    with make_sim(scene) as sim:
        sim.step(1)
        start = tool_pose(sim)[0]
        sim.world.set_pose("cube", tuple((start + np.array([0.0, 0.0, -0.12])).tolist()))
        sim.components["arm"].command(MoveTo(tuple((start + np.array([0.0, 0.0, -0.2])).tolist())))
        first = None
        for _ in range(480):
            sim.step(1)
            if first is None and sim.readings["touch"].in_contact:
                first = sim.world.tick
            if [r for r in sim.trace if r["kind"] == "protective_stop"]:
                break
        stops = [r for r in sim.trace if r["kind"] == "protective_stop"]
        assert len(stops) == 1 and stops[0]["actuator"] == "arm" and first is not None
        assert stops[0]["reason"].startswith("contact with cube (") and stops[0]["reason"].endswith("(touch)")
        assert stops[0]["tick"] - first <= 1
        state = sim.readings["arm"]
        assert state.stopped and state.status == "failed"
        held = arm_angles(sim)
        sim.components["arm"].command(MoveTo(tuple((start + np.array([0.1, 0.1, 0.1])).tolist())))
        sim.step(120)
        assert np.max(np.abs(arm_angles(sim) - held)) < 0.02, "a move after a stop_on stop was ignored"
        assert sim.readings["arm"].stopped


@PROPS
@given(st.lists(st.floats(-0.3, 0.3), min_size=7, max_size=7))
def test_the_numpy_solve_of_the_rest_pose_comes_back_to_it(sim, start: list[float]) -> None:
    """The solve's null-space pull goes to the rest pose: asked for the tool frame the rest pose gives, from joint
    angles up to 0.3 rad away, it reaches the frame and ends nearer the rest pose than it started (the arm is
    redundant: without the pull any of a curve of answers would do)."""
    arm = sim.components["arm"]
    before = arm_angles(sim)
    rest = np.array(arm.rest[arm.arm_cols])
    try:
        set_arm(sim, rest)
        w = sim.world
        panda = w.body("panda")
        pos = tool_pose(sim)[0]
        orn = tuple(float(v) for v in np.array(w.pose(panda, w.link(panda, "panda_hand"))[1]))
        target = hamilton(orn, axis_angle_quaternion(*_axis_angle(TOOL)))
        q_all = arm._measured_all()
        q_all[arm.arm_cols] = rest + np.array(start)
        q, ep, _ = arm._solve_numpy(q_all, pos, target)
        answer = q[arm.arm_cols]
        assert ep < arm.config.ik_tolerance
        assert np.linalg.norm(answer - rest) < np.linalg.norm(np.array(start)) + 1e-6
    finally:
        set_arm(sim, before)
