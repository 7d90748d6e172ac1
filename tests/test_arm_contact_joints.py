"""contact sensor, joint_control modes, and the Kuka's stop on contact (lessons 03 and 04)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from robokit.msgs.arm import JointCommand
from robokit.testing import PLANE, make_sim

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
KUKA = {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}


def test_contact_sensor_reports_a_resting_box() -> None:
    cfg = {
        "bodies": {"plane": PLANE,
                   "box": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 2.0, "position": [0, 0, 0.5]},
                   "far": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0, "position": [3, 0, 0.05]}},
        "sensors": {"box_any": {"type": "contact", "body": "box"},
                    "box_far": {"type": "contact", "body": "box", "other": "far"}},
    }
    with make_sim(cfg) as sim:
        sim.step(1)
        assert not sim.readings["box_any"].in_contact
        sim.step(480)
        c = sim.readings["box_any"]
        assert c.in_contact and c.others == ("plane",) and c.points >= 4
        assert c.normal_force == pytest.approx(2.0 * 9.81, rel=0.05)
        assert not sim.readings["box_far"].in_contact


def test_joint_control_position_velocity_and_torque_modes() -> None:
    cfg = {"bodies": {"plane": PLANE}, "robots": {"kuka": KUKA},
           "actuators": {"joints": {"type": "joint_control", "body": "kuka", "max_force": 300.0}}}
    with make_sim(cfg) as sim:
        joints = sim.components["joints"]
        joints.command(JointCommand("position", {"lbr_iiwa_joint_1": 0.8}))
        sim.step(480)
        assert sim.readings["joints"].positions["lbr_iiwa_joint_1"] == pytest.approx(0.8, abs=0.01)
        joints.command(JointCommand("velocity", {"lbr_iiwa_joint_1": 0.5}))
        sim.step(240)
        assert sim.readings["joints"].velocities["lbr_iiwa_joint_1"] == pytest.approx(0.5, abs=0.02)
        joints.command(JointCommand("velocity", {"lbr_iiwa_joint_1": 0.0}))
        sim.step(60)
        # torque mode: the default motor is switched off first, so 5 N·m spins the base joint up
        joints.command(JointCommand("torque", {"lbr_iiwa_joint_1": 5.0}))
        start = sim.readings["joints"].positions["lbr_iiwa_joint_1"]
        sim.step(30)
        r = sim.readings["joints"]
        assert r.positions["lbr_iiwa_joint_1"] > start + 0.1 and r.velocities["lbr_iiwa_joint_1"] > 1.0
        assert r.torques["lbr_iiwa_joint_1"] == 5.0
        assert r.mode == "torque"
        with pytest.raises(ValueError, match="unknown joint 'elbow'"):
            joints.command(JointCommand("position", {"elbow": 0.1}))


def test_kuka_dance_follows_its_sine_program() -> None:
    with make_sim(CONFIGS / "kuka_dance.toml") as sim:
        sim.scheduler.behaviour = None
        sim.step(480)  # 2 s
        wave = sim.components["joints"].config.sine["lbr_iiwa_joint_1"]
        expected = wave.amplitude * math.sin(2 * math.pi * wave.frequency_hz * sim.world.time)
        assert sim.readings["joints"].positions["lbr_iiwa_joint_1"] == pytest.approx(expected, abs=0.1)


def first_tick(sim: Any, pred: Any, limit: int) -> int:
    for _ in range(limit):
        sim.step(1)
        if pred(sim):
            return int(sim.world.tick)
    raise AssertionError("condition never held")


def test_contact_stop_halts_the_kuka_within_a_few_ticks() -> None:
    with make_sim(CONFIGS / "contact_stop.toml") as sim:
        sim.scheduler.behaviour = None
        box_start = sim.world.pose("box")[0]
        touched = first_tick(sim, lambda s: s.readings["bump"].in_contact, 1200)
        stopped = first_tick(sim, lambda s: s.readings["joints"].stopped, 10) if not \
            sim.readings["joints"].stopped else touched
        assert stopped - touched <= 1  # the stop is applied in the first update after the contact
        assert "contact with box" in sim.readings["joints"].stop_reason
        speeds = []
        for _ in range(12):
            sim.step(1)
            speeds.append(max(abs(v) for v in sim.readings["joints"].velocities.values()))
        assert speeds[-1] < 0.01  # at rest within a few ticks (it moved at up to 0.5 rad/s)
        sim.step(240)
        assert max(abs(v) for v in sim.readings["joints"].velocities.values()) < 0.005
        assert math.dist(sim.world.pose("box")[0], box_start) < 0.01  # pushed by millimetres, not knocked off
        assert any(r["kind"] == "safety_stop" for r in sim.trace)
