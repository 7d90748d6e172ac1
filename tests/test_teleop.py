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
