"""gripper: friction hold while the arm moves, holding goes false when the object is taken away, coupling."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from robokit.msgs.arm import GripperCommand, MoveTo
from robokit.testing import make_sim

READY = {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8, "panda_joint7": 0.785}
SCENE: dict[str, Any] = {
    "bodies": {
        "table": {"urdf": "table/table.urdf", "position": [0.5, 0, -0.626], "fixed_base": True},
        "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0.5, 0.0, 0.025],
                 "lateral_friction": 0.8},
    },
    "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {
        "arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget", "ready_pose": READY},
        "gripper": {"type": "gripper", "body": "panda"},
    },
}


def until(sim: Any, pred: Any, ticks: int = 600) -> None:
    sim.step(1)
    assert sim.run_until(pred, ticks)


def grasped(sim: Any) -> None:
    """Move down around the cube and close: the fixture of every hold test."""
    sim.components["arm"].command(MoveTo((0.5, 0.0, 0.025)))
    until(sim, lambda s: s.readings["arm"].reached)
    sim.components["gripper"].command(GripperCommand("close"))
    until(sim, lambda s: s.readings["gripper"].settled)


def test_holds_a_cube_by_friction_while_the_arm_moves() -> None:
    with make_sim(SCENE) as sim:
        assert sim.readings["gripper"].width == pytest.approx(0.08, abs=1e-6)
        grasped(sim)
        g = sim.readings["gripper"]
        assert g.holding and g.held == "cube"
        assert g.width == pytest.approx(0.05, abs=0.003)
        for target in [(0.5, 0.0, 0.2), (0.3, 0.3, 0.25), (0.4, -0.3, 0.15), (0.55, 0.1, 0.3)]:
            sim.components["arm"].command(MoveTo(target))
            sim.step(1)
            while not sim.readings["arm"].reached:
                assert sim.readings["gripper"].holding
                sim.step(1)
            cube = np.array(sim.world.pose("cube")[0])
            assert np.linalg.norm(cube - np.array(sim.readings["arm"].position)) < 0.01
        assert sim.world.client.getNumConstraints() == 1  # the finger gear only: nothing welded


@pytest.mark.parametrize("how", ["remove_body", "set_pose"])
def test_holding_goes_false_when_the_cube_is_taken(how: str) -> None:
    with make_sim(SCENE) as sim:
        grasped(sim)
        sim.components["arm"].command(MoveTo((0.5, 0.0, 0.2)))
        until(sim, lambda s: s.readings["arm"].reached)
        assert sim.readings["gripper"].holding
        if how == "remove_body":
            sim.world.remove_body("cube")
        else:
            sim.world.set_pose("cube", (0.7, 0.3, 0.025))
        sim.step(2)
        g = sim.readings["gripper"]
        assert not g.holding and g.held is None
        until(sim, lambda s: s.readings["gripper"].settled, 120)
        assert sim.readings["gripper"].width < 0.004  # closed on nothing


def test_fingers_stay_symmetric_and_close_on_nothing_is_not_holding() -> None:
    with make_sim(SCENE) as sim:
        sim.components["gripper"].command(GripperCommand("width", width=0.03))
        until(sim, lambda s: s.readings["gripper"].settled)
        client, body = sim.world.client, sim.world.body("panda")
        a = client.getJointState(body, sim.world.joint("panda", "panda_finger_joint1").index)[0]
        b = client.getJointState(body, sim.world.joint("panda", "panda_finger_joint2").index)[0]
        assert a == pytest.approx(0.015, abs=1e-3) and b == pytest.approx(a, abs=5e-4)
        sim.components["gripper"].command(GripperCommand("close"))
        until(sim, lambda s: s.readings["gripper"].settled)
        assert not sim.readings["gripper"].holding


def test_bad_command_is_a_clear_error() -> None:
    with make_sim(SCENE) as sim, pytest.raises(ValueError, match="gripper takes GripperCommand"):
        sim.components["gripper"].command("close")
    with pytest.raises(ValueError, match="gripper action must be one of"):
        GripperCommand("squeeze")
