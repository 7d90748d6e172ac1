"""diff_drive's promises, each expectation derived by hand: wheel speeds from (v, omega) and the drive's geometry,
the speed limit that keeps a Twist's curvature, the acceleration ramp in m/s^2 of rim speed, odometry against the
true pose (sign and wrap of the heading), the sign of the forward speed, contacts without the ground."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.msgs.mobile import STOP, Twist, WheelSpeeds
from robokit.testing import PLANE, make_sim

DIFFBOT = {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}
R, B, MAX_W, ACC = 0.05, 0.26, 20.0, 2.0  # the defaults: wheel radius, track, wheel speed limit, m/s^2
DT = 1.0 / 240.0


def config(**drive: object) -> dict:
    return {"bodies": {"plane": PLANE}, "robots": {"robot": DIFFBOT},
            "actuators": {"drive": {"type": "diff_drive", **drive}}}


@pytest.fixture(scope="module")
def drive():
    with make_sim(config()) as sim:
        yield sim.components["drive"]


def by_hand(v: float, omega: float) -> tuple[float, float]:
    """Left and right wheel speeds (rad/s) of a differential drive, then scaled to the limit keeping the ratio."""
    left, right = (v - omega * B / 2) / R, (v + omega * B / 2) / R
    peak = max(abs(left), abs(right))
    k = MAX_W / peak if peak > MAX_W else 1.0
    return left * k, right * k


@settings(max_examples=200, deadline=None)
@given(v=st.floats(-2.0, 2.0), omega=st.floats(-8.0, 8.0))
def test_wheel_speeds_follow_the_geometry_and_keep_the_curvature(drive, v: float, omega: float) -> None:
    left, right = drive.wheel_targets(Twist(v, omega))
    want = by_hand(v, omega)
    assert left == pytest.approx(want[0], abs=1e-9) and right == pytest.approx(want[1], abs=1e-9)
    assert max(abs(left), abs(right)) <= MAX_W + 1e-9


@pytest.mark.parametrize(("v", "omega", "left", "right"), [
    (0.5, 0.0, 10.0, 10.0),          # straight: v / r on both wheels
    (0.0, 1.0, -2.6, 2.6),           # turning left (counter-clockwise): the right wheel forward
    (-2.0, 0.0, -20.0, -20.0),       # reverse beyond the limit: clipped to -20 rad/s
    (0.1, 0.0, 2.0, 2.0),            # slow: not scaled up
])
def test_wheel_speeds_examples(drive, v: float, omega: float, left: float, right: float) -> None:
    assert drive.wheel_targets(Twist(v, omega)) == pytest.approx((left, right))


def test_raw_wheel_speeds_are_clipped_keeping_their_ratio(drive) -> None:
    assert drive.wheel_targets(WheelSpeeds(-40.0, 10.0)) == pytest.approx((-20.0, 5.0))


def test_speed_ramps_at_max_acceleration_up_and_down() -> None:
    """Rim speed changes by at most max_acceleration * dt per tick: 2 m/s^2 / 0.05 m = 40 rad/s^2 of wheel."""
    step = ACC / R * DT
    with make_sim(config()) as sim:
        d = sim.components["drive"]
        d.command(Twist(0.5, 0.0))  # target 10 rad/s: reached after 0.25 s
        sim.step(2)
        for _ in range(30):
            before = d.speeds[0]
            sim.step(1)
            assert d.speeds[0] - before == pytest.approx(step, abs=1e-9)
        sim.step(60)
        assert d.speeds == pytest.approx((10.0, 10.0))
        d.command(STOP)
        sim.step(1)
        for _ in range(10):
            before = d.speeds[0]
            sim.step(1)
            assert before - d.speeds[0] == pytest.approx(step, abs=1e-9)


def test_odometry_heading_turns_the_right_way_and_stays_wrapped() -> None:
    """Turning in place counter-clockwise for more than a full turn: the odometry heading follows the true one
    (same sign, within a few degrees) and always lies in (-pi, pi]."""
    with make_sim(config()) as sim:
        d = sim.components["drive"]
        d.command(Twist(0.0, 2.0))
        true_turned, last = 0.0, sim.readings["drive"].pose[2]
        odo_turned, odo_last = 0.0, sim.readings["drive"].odometry[2]
        for _ in range(100):  # 4 s at ~2 rad/s: more than a full turn
            sim.step(10)
            state = sim.readings["drive"]
            assert -math.pi <= state.odometry[2] <= math.pi
            true_turned += math.remainder(state.pose[2] - last, 2 * math.pi)
            odo_turned += math.remainder(state.odometry[2] - odo_last, 2 * math.pi)
            last, odo_last = state.pose[2], state.odometry[2]
    assert true_turned > 2 * math.pi
    assert odo_turned > 0 and abs(odo_turned - true_turned) < 0.15 * true_turned  # skid: odometry a little off


def test_odometry_follows_an_arc() -> None:
    """An arc to the left: odometry's position and heading stay within a few cm / degrees of the true pose."""
    with make_sim(config()) as sim:
        sim.components["drive"].command(Twist(0.3, 0.6))
        sim.step(480)
        state = sim.readings["drive"]
    x, y, yaw = state.pose
    ox, oy, oyaw = state.odometry
    assert y > 0.1 and yaw > 0.5  # it went left
    assert math.hypot(ox - x, oy - y) < 0.05
    assert abs(math.remainder(oyaw - yaw, 2 * math.pi)) < 0.1


def test_reverse_speed_is_negative_and_nothing_touches_on_an_empty_floor() -> None:
    with make_sim(config()) as sim:
        sim.components["drive"].command(Twist(-0.2, 0.0))
        sim.step(240)
        state = sim.readings["drive"]
    assert state.v == pytest.approx(-0.2, rel=0.1)
    assert state.pose[0] < -0.1
    assert state.contacts == ()  # the plane is ignored


@settings(max_examples=10, deadline=None)
@given(v=st.floats(-0.4, 0.4), omega=st.floats(-1.5, 1.5))
def test_odometry_tracks_the_true_pose_for_any_arc(v: float, omega: float) -> None:
    """Any (v, omega) held for 1.5 s from rest: odometry ends within 5 cm and 0.1 rad of the true pose, and the
    true path turned the way omega says (counter-clockwise for omega > 0)."""
    with make_sim(config()) as sim:
        sim.components["drive"].command(Twist(v, omega))
        sim.step(360)
        state = sim.readings["drive"]
    x, y, yaw = state.pose
    ox, oy, oyaw = state.odometry
    assert math.hypot(ox - x, oy - y) < 0.05
    assert abs(math.remainder(oyaw - yaw, 2 * math.pi)) < 0.1
    if abs(omega) > 0.3:
        assert math.copysign(1.0, yaw) == math.copysign(1.0, omega)
