"""Standard messages with frames and signs (robokit.msgs.Wrench, Imu) and the built-in force_torque sensor.

Expectations come from the robot model itself: the wrist carries the hand and fingers, whose masses pybullet reads
from the URDF, so a hand hanging still must receive ``m g`` upwards from the flange (REP 103: world z up).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest

from robokit.msgs import Imu, Wrench
from robokit.testing import check_sensor, make_sim

G = 9.81
READY = {"panda_joint1": 0.0, "panda_joint2": -0.4, "panda_joint3": 0.0, "panda_joint4": -2.2, "panda_joint5": 0.0,
         "panda_joint6": 1.8, "panda_joint7": 0.785}


def scene(world_frame: bool) -> dict[str, Any]:
    return {
        "world": {"max_time": 2.0},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, -0.6]}},
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "sensors": {"wrist": {"type": "force_torque", "body": "panda", "joint": "panda_hand_joint",
                              "world_frame": world_frame}},
        "actuators": {"arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget",
                              "ready_pose": READY}},
    }


def _carried_mass(sim: Any) -> float:
    """Mass below the wrist joint: the hand and every link after it (fingers, grasp target), from the URDF."""
    c, panda = sim.world.client, sim.world.body("panda")
    hand = sim.world.joint("panda", "panda_hand_joint").index
    return sum(c.getDynamicsInfo(panda, k)[0] for k in range(hand, c.getNumJoints(panda)))


def test_a_hanging_hand_receives_its_weight_upwards_in_the_world_frame() -> None:
    with make_sim(scene(world_frame=True)) as sim:
        sim.step(240)
        w: Wrench = sim.readings["wrist"]
        weight = _carried_mass(sim) * G
    assert w.frame == "world" and w.time == pytest.approx(1.0)
    assert w.force == pytest.approx((0.0, 0.0, weight), abs=0.05 * weight)
    assert w.force_norm == pytest.approx(weight, rel=0.05)


def test_in_the_hand_frame_the_same_force_points_along_the_hands_up_axis() -> None:
    with make_sim(scene(world_frame=False)) as sim:
        sim.step(240)
        w: Wrench = sim.readings["wrist"]
        c, panda = sim.world.client, sim.world.body("panda")
        hand = sim.world.link("panda", "panda_hand")
        rot = np.asarray(c.getMatrixFromQuaternion(c.getLinkState(panda, hand)[5])).reshape(3, 3)
        expected = rot.T @ np.array([0.0, 0.0, _carried_mass(sim) * G])  # world "up" seen in the hand frame
    assert w.frame == "panda_hand"
    assert w.force == pytest.approx(tuple(expected), abs=0.05 * float(np.linalg.norm(expected)))
    assert expected[2] < -0.9 * np.linalg.norm(expected)  # the hand points down: up is its -z


def test_pressing_down_turns_the_force_downwards() -> None:
    """The sign convention at work: an arm driving its hand into the table pushes the hand down through the wrist,
    so the force the hand receives from the flange points down (negative world z), many times its weight."""
    from robokit.config import read_toml

    raw = read_toml("configs/contact_abort.toml")
    del raw["monitors"]
    raw["sensors"]["wrist"]["world_frame"] = True
    with make_sim(raw, base_dir="configs") as sim:
        sim.step(600)  # pressing into the table since ~0.6 s
        w: Wrench = sim.readings["wrist"]
        weight = _carried_mass(sim) * G
    assert w.force[2] < -10 * weight  # the arm drives the hand down: hundreds of newtons, downwards


def test_the_sensor_is_switched_off_when_closed() -> None:
    with make_sim(scene(world_frame=False)) as sim:
        sim.step(10)
        sensor = sim.components["wrist"]
        c, panda, joint = sim.world.client, sim.world.body("panda"), sensor.index
        assert any(abs(v) > 1.0 for v in c.getJointState(panda, joint)[2])
        sensor.close()
        sim.step(1)
        assert c.getJointState(panda, joint)[2] == (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # pybullet no longer measures


def test_force_torque_passes_the_sensor_conformance_checks() -> None:
    check_sensor("force_torque")


def test_messages_name_their_frame_and_are_frozen() -> None:
    with pytest.raises(TypeError):
        Wrench((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))  # type: ignore[call-arg]  # no frame: refused
    imu = Imu((0.0, 0.0, G), (0.0, 0.0, 0.0), "base_link", 0.5)
    assert imu.orientation is None and imu.frame == "base_link"
    with pytest.raises(dataclasses.FrozenInstanceError):
        imu.frame = "world"  # type: ignore[misc]
    assert Wrench((3.0, 4.0, 0.0), (0.0, 0.0, 12.0), "world").force_norm == 5.0
    assert math.isclose(Wrench((0.0, 0.0, 0.0), (0.0, 5.0, 12.0), "world").torque_norm, 13.0)
