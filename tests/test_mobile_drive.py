"""diff_drive on the bundled diffbot and on Husky: (v, omega) tracking, odometry, config errors."""

from __future__ import annotations

import math

import pytest

from robokit.cli import main
from robokit.msgs.mobile import DriveState, Twist, WheelSpeeds
from robokit.testing import PLANE, make_sim

DIFFBOT = {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}


def drive_config(robot: dict | None = None, **drive: object) -> dict:
    return {
        "bodies": {"plane": PLANE},
        "robots": {"robot": robot or DIFFBOT},
        "actuators": {"drive": {"type": "diff_drive", **drive}},
    }


def measure(sim, cmd, settle: float = 1.0, span: float = 2.0) -> tuple[float, float]:
    """Mean forward speed (m/s) and yaw rate (rad/s) over ``span`` s after ``settle`` s under ``cmd``."""
    sim.components["drive"].command(cmd)
    sim.step(round(settle * 240))
    x0, y0, yaw0 = sim.readings["drive"].pose
    turned, last = 0.0, yaw0
    for _ in range(round(span * 240 / 12)):
        sim.step(12)
        yaw = sim.readings["drive"].pose[2]
        turned += math.remainder(yaw - last, 2 * math.pi)
        last = yaw
    x1, y1, _ = sim.readings["drive"].pose
    return math.hypot(x1 - x0, y1 - y0) / span, turned / span


@pytest.mark.parametrize("v", [0.2, 0.4])
def test_straight_speed_within_5_percent(v: float) -> None:
    with make_sim(drive_config()) as sim:
        speed, rate = measure(sim, Twist(v, 0.0))
    assert speed == pytest.approx(v, rel=0.05)
    assert abs(rate) < 0.02


@pytest.mark.parametrize("omega", [1.0, -2.0])
def test_turn_rate_within_5_percent(omega: float) -> None:
    with make_sim(drive_config()) as sim:
        _, rate = measure(sim, Twist(0.0, omega))
    assert rate == pytest.approx(omega, rel=0.05)


def test_arc_and_odometry() -> None:
    with make_sim(drive_config()) as sim:
        speed, rate = measure(sim, Twist(0.3, 0.5))
        state: DriveState = sim.readings["drive"]
    assert speed == pytest.approx(0.3, rel=0.05)
    assert rate == pytest.approx(0.5, rel=0.05)
    x, y, yaw = state.pose
    ox, oy, oyaw = state.odometry
    assert math.hypot(x - ox, y - oy) < 0.05  # wheel odometry agrees with the true pose on a flat floor
    assert abs(math.remainder(yaw - oyaw, 2 * math.pi)) < 0.05
    assert state.distance == pytest.approx(0.3 * 3.0, rel=0.08)


def test_raw_wheel_speeds_and_caster_motor_off() -> None:
    with make_sim(drive_config()) as sim:
        speed, rate = measure(sim, WheelSpeeds(4.0, 4.0))
        caster = sim.world.joint("robot", "caster_wheel").index
        # a passive caster with its motor off rolls freely instead of braking the robot
        assert abs(sim.world.client.getJointState(sim.world.body("robot"), caster)[1]) > 1.0
    assert speed == pytest.approx(4.0 * 0.05, rel=0.05)
    assert abs(rate) < 0.02


def test_husky_skid_steer_by_config() -> None:
    husky = {"urdf": "husky/husky.urdf", "position": [0, 0, 0.2]}
    cfg = drive_config(husky, left_wheels=["front_left_wheel", "rear_left_wheel"],
                       right_wheels=["front_right_wheel", "rear_right_wheel"], wheel_radius=0.17775,
                       track_width=2.0, max_wheel_force=50.0)  # effective track: the wheels scrub
    with make_sim(cfg) as sim:
        speed, _ = measure(sim, Twist(0.5, 0.0))
        _, rate = measure(sim, Twist(0.0, 0.5), settle=0.5)
    assert speed == pytest.approx(0.5, rel=0.05)
    assert rate == pytest.approx(0.5, rel=0.2)  # skid-steer: only roughly, it slips


def test_bad_command_is_a_clear_error() -> None:
    with make_sim(drive_config()) as sim, pytest.raises(ValueError, match="Twist"):
        sim.components["drive"].command((1.0, 0.0))


def test_unknown_wheel_joint_is_one_line_at_validate(tmp_path, capsys) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(
        '[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'
        '[robots.robot]\nurdf = "robots/diffbot.urdf"\nposition = [0, 0, 0.06]\n'
        '[actuators.drive]\ntype = "diff_drive"\nleft_wheels = ["left_wheel_joint"]\n'
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "actuators.drive.left_wheels[0]" in err and "unknown joint 'left_wheel_joint'" in err
    assert "left_wheel" in err and "Traceback" not in err
