"""Arm config errors: each one clear line at ``robokit validate``, exit code 2, no traceback."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from robokit.cli import main
from robokit.testing import edited_config, validate_error

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"


CASES = [
    ('ee_link = "panda_grasptarget"', 'ee_link = "panda_tcp"',
     r"actuators\.arm\.ee_link: unknown link 'panda_tcp' in panda.*valid: .*panda_grasptarget"),
    ('finger_joints = ["panda_finger_joint1", "panda_finger_joint2"]',
     'finger_joints = ["panda_finger_joint1", "panda_finger_joint3"]',
     r"actuators\.gripper\.finger_joints\[1\]: unknown joint 'panda_finger_joint3' in panda.*panda_finger_joint2"),
    ('[actuators.gripper]\ntype = "gripper"\nbody = "panda"\n'
     'finger_joints = ["panda_finger_joint1", "panda_finger_joint2"]\nforce = 20.0\nlateral_friction = 1.2\n', '',
     r"behaviour\.gripper: pick_place needs a gripper actuator named 'gripper', but there is none"),
    ('ready_pose = { panda_joint1 = 0.0,', 'ready_pose = { panda_jiont1 = 0.0,',
     r"actuators\.arm\.ready_pose: unknown joint 'panda_jiont1'"),
    ('[sensors.poses]\ntype = "body_pose"\nbodies = ["cube"]', '[sensors.poses]\ntype = "contact"\nbody = "cubes"',
     r"sensors\.poses\.body: unknown body 'cubes'"),
    ('ee_link = "panda_grasptarget"', 'ee_link = "panda_link0"',
     r"actuators\.arm\.ee_link: the end-effector link must not be the base link 'panda_link0'"),
]


@pytest.mark.parametrize(("old", "new", "expected"), CASES, ids=["ee_link", "finger", "no_gripper", "ready",
                                                                  "contact_body", "ee_base_link"])
def test_validate_gives_one_clear_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str,
                                       expected: str) -> None:
    line = validate_error(edited_config(CONFIG, tmp_path, old, new, name="broken.toml"))
    assert re.search(expected, line), line


def test_the_shipped_arm_configs_validate(capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("pick_place.toml", "kuka_dance.toml", "contact_stop.toml"):
        assert main(["validate", str(CONFIG.parent / name)]) == 0
    assert capsys.readouterr().out.count(": ok (") == 3


@pytest.mark.parametrize("arm_type", ["ik_arm", "ee_delta"])
def test_both_arm_types_refuse_the_base_link_as_end_effector(arm_type: str) -> None:
    from robokit.errors import ConfigError
    from robokit.testing import make_sim

    scene = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
             "actuators": {"arm": {"type": arm_type, "body": "panda", "ee_link": "panda_link0"}}}
    with pytest.raises(ConfigError, match="end-effector link must not be the base link 'panda_link0'") as err:
        make_sim(scene).close()
    assert err.value.key.endswith("ee_link")


@pytest.mark.parametrize(("arm_type", "setting", "key"), [
    ("ik_arm", {"ready_pose": {"elbow": 0.1}}, "ready_pose"),
    ("ik_arm", {"rest_pose": {"elbow": 0.1}}, "rest_pose"),
    ("ik_arm", {"limits": {"elbow": [-1.0, 1.0]}}, "limits"),
    ("ee_delta", {"ready_pose": {"elbow": 0.1}}, "ready_pose.elbow"),
])
def test_an_unknown_joint_name_is_refused_at_its_key(arm_type: str, setting: dict[str, object], key: str) -> None:
    from robokit.errors import ConfigError
    from robokit.testing import make_sim

    scene = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
             "actuators": {"arm": {"type": arm_type, "body": "panda", "ee_link": "panda_grasptarget", **setting}}}
    with pytest.raises(ConfigError) as err:
        make_sim(scene).close()
    movable = ", ".join([f"panda_joint{k}" for k in range(1, 8)] + ["panda_finger_joint1", "panda_finger_joint2"])
    assert err.value.key == f"actuators.arm.{key}"
    assert err.value.message == f"unknown joint 'elbow'; movable joints: {movable}"
