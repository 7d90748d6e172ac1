"""Keyboard teleop (lessons 03 and 07), driven headless by the keyboard sensor's timed script."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from robokit.testing import make_sim

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def test_keyboard_script_gives_held_and_newly_pressed_keys() -> None:
    config = {
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
        "sensors": {"keys": {"type": "keyboard", "script": [{"at": 0.1, "keys": ["up", "3"], "hold": 0.1}]}},
    }
    with make_sim(config) as sim:
        sim.step(25)  # ticks 0..24; tick 24 (t = 0.1 s) is the first that sees the press
        first = sim.readings["keys"]
        sim.step(1)
        held = sim.readings["keys"]
        sim.step(24)
        released = sim.readings["keys"]
    assert first.down == {"up", "3"} and first.pressed == {"up", "3"}
    assert held.down == {"up", "3"} and held.pressed == frozenset()
    assert released.down == frozenset()


def test_drive_teleop_follows_the_arrow_script() -> None:
    with make_sim(CONFIGS / "drive_teleop.toml") as sim:
        result = sim.run()
    assert result.outcome == "succeeded" and "quit key" in result.reason
    x, y, yaw = result.result["final_pose"]
    # up for 2 s at 0.5 m/s, left for 1.05 s at 1.5 rad/s (~90 degrees), up for 2 s: an L to about (1, 1),
    # less whatever the motors lose to acceleration and wheel slip
    assert x == pytest.approx(1.0, abs=0.25)
    assert y == pytest.approx(1.0, abs=0.25)
    assert yaw == pytest.approx(math.pi / 2, abs=0.35)


def test_unknown_scripted_key_is_a_config_error(tmp_path: Path) -> None:
    from robokit.errors import ConfigError

    config = {"sensors": {"keys": {"type": "keyboard", "script": [{"at": 0, "keys": ["f13"]}]}}}
    with pytest.raises(ConfigError, match=r"sensors.keys.script\[0\].keys: unknown key 'f13'"):
        make_sim(config)


def test_joint_teleop_selects_joints_and_turns_them() -> None:
    with make_sim(CONFIGS / "kuka_teleop.toml") as sim:
        result = sim.run()
        positions = sim.readings["joints"].positions
    assert result.outcome == "succeeded"
    assert result.result["selections"] == ["lbr_iiwa_joint_1", "lbr_iiwa_joint_4"]
    # right held 1 s at 1 rad/s on joint 1, left held 0.5 s on joint 4; the others stay at 0
    assert result.result["targets"]["lbr_iiwa_joint_1"] == pytest.approx(1.0, abs=0.01)
    assert result.result["targets"]["lbr_iiwa_joint_4"] == pytest.approx(-0.5, abs=0.01)
    assert positions["lbr_iiwa_joint_1"] == pytest.approx(1.0, abs=0.05)  # the arm really moved there
    assert positions["lbr_iiwa_joint_4"] == pytest.approx(-0.5, abs=0.05)
    assert positions["lbr_iiwa_joint_2"] == pytest.approx(0.0, abs=0.05)


def kuka_teleop(script: list[dict[str, object]], rate_hz: float | None = None) -> dict[str, object]:
    import tomllib

    raw = tomllib.loads((CONFIGS / "kuka_teleop.toml").read_text(encoding="utf-8"))
    raw["sensors"]["keys"]["script"] = script
    if rate_hz is not None:
        raw["sensors"]["keys"]["rate_hz"] = rate_hz
        raw["behaviour"]["rate_hz"] = rate_hz
    return raw


def test_teleop_targets_stop_at_the_joint_limits() -> None:
    # right held for 4 s at 1 rad/s on joint 1 (limits about +-2.97 rad): the target stops at the upper limit
    raw = kuka_teleop([{"at": 0.1, "keys": ["1"], "hold": 0.05}, {"at": 0.2, "keys": ["right"], "hold": 4.0},
                       {"at": 4.5, "keys": ["q"]}])
    with make_sim(raw, base_dir=CONFIGS) as sim:
        upper = sim.world.joint("kuka", "lbr_iiwa_joint_1").upper
        result = sim.run()
        measured = sim.readings["joints"].positions["lbr_iiwa_joint_1"]
    assert 2.5 < upper < 3.2  # the URDF's limit, read independently of the behaviour
    assert result.result["targets"]["lbr_iiwa_joint_1"] == pytest.approx(upper, abs=1e-6)
    assert measured <= upper + 0.02


def test_a_tap_between_two_keyboard_readings_still_moves_one_step() -> None:
    # keyboard and teleop at 10 Hz (readings at 0.5 s and 0.6 s); the tap lasts 10 ms in between
    raw = kuka_teleop([{"at": 0.1, "keys": ["1"], "hold": 0.01}, {"at": 0.52, "keys": ["right"], "hold": 0.01},
                       {"at": 1.0, "keys": ["q"]}], rate_hz=10)
    with make_sim(raw, base_dir=CONFIGS) as sim:
        result = sim.run()
    assert result.result["selections"] == ["lbr_iiwa_joint_1"]  # the 10 ms selection tap was not lost either
    # one step of the 10 Hz behaviour at 1 rad/s
    assert result.result["targets"]["lbr_iiwa_joint_1"] == pytest.approx(0.1, abs=1e-6)


def test_gui_key_events_decode_taps_holds_and_new_presses() -> None:
    import pybullet as p
    from robokit_plugins.keyboard import decode_events

    tap = decode_events({ord("a"): p.KEY_WAS_TRIGGERED | p.KEY_WAS_RELEASED}, frozenset())
    assert tap.down == frozenset() and tap.pressed == {"a"}
    held = decode_events({p.B3G_LEFT_ARROW: p.KEY_IS_DOWN}, frozenset({"left"}))
    assert held.down == {"left"} and held.pressed == frozenset()
    new = decode_events({ord("1"): p.KEY_IS_DOWN | p.KEY_WAS_TRIGGERED, 99999: p.KEY_IS_DOWN}, frozenset())
    assert new.down == {"1"} and new.pressed == {"1"}  # unknown key codes are ignored
    missed_trigger = decode_events({p.B3G_UP_ARROW: p.KEY_IS_DOWN}, frozenset())
    assert missed_trigger.pressed == {"up"}  # down now, not down before: newly pressed


def test_drive_teleop_right_arrow_turns_clockwise_and_down_reverses() -> None:
    import tomllib

    raw = tomllib.loads((CONFIGS / "drive_teleop.toml").read_text(encoding="utf-8"))
    raw["sensors"]["keys"]["script"] = [{"at": 0.5, "keys": ["down"], "hold": 2.0},
                                        {"at": 2.5, "keys": ["right"], "hold": 1.05}, {"at": 4.0, "keys": ["q"]}]
    with make_sim(raw, base_dir=CONFIGS) as sim:
        result = sim.run()
    x, y, yaw = result.result["final_pose"]
    # back 2 s at 0.5 m/s (about -1 m in x), then a quarter turn clockwise in place
    assert x == pytest.approx(-1.0, abs=0.25) and y == pytest.approx(0.0, abs=0.15)
    assert yaw == pytest.approx(-math.pi / 2, abs=0.35)
