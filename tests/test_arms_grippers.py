"""Other arms and tools: SDF/MJCF models, mounting a tool on a flange, any parallel gripper by config, suction,
and sensors fixed in the world (lesson 04's rays on stands). Real physics, DIRECT mode."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robokit.errors import ConfigError
from robokit.msgs.arm import GripperCommand, JointCommand
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
PLANE = {"urdf": "plane.urdf", "position": [0, 0, 0]}
KUKA_SDF = {"sdf": "kuka_iiwa/kuka_with_gripper2.sdf", "position": [0.3, -0.2, 0.0], "fixed_base": True}
KUKA_GRIPPER = {
    "type": "gripper", "body": "kuka", "finger_joints": ["base_left_finger_joint", "base_right_finger_joint"],
    "open_positions": [-0.22, 0.22], "closed_positions": [0.05, -0.05], "open_width": 0.084,
    "hold_joints": {"left_base_tip_joint": 0.0, "right_base_tip_joint": 0.0},
}


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)


# ----------------------------------------------------------------------------------------- SDF / MJCF
def test_sdf_model_is_placed_by_its_base_link_frame_and_stays_fixed() -> None:
    with make_sim({"bodies": {"plane": PLANE}, "robots": {"kuka": KUKA_SDF}}) as sim:
        w = sim.world
        assert "base_link" in w.link_names("kuka") and "left_finger_tip" in w.link_names("kuka")
        # The first arm joint sits straight above the base link frame: at the configured x, y.
        link1 = w.pose("kuka", w.link("kuka", "lbr_iiwa_link_1"))[0]
        assert link1[0] == pytest.approx(0.3, abs=1e-6) and link1[1] == pytest.approx(-0.2, abs=1e-6)
        sim.step(240)
        assert w.pose("kuka", w.link("kuka", "lbr_iiwa_link_1"))[0][0] == pytest.approx(0.3, abs=1e-6)


def test_mjcf_every_model_becomes_a_named_body() -> None:
    with make_sim({"bodies": {"plane": PLANE, "ant": {"mjcf": "mjcf/ant.xml", "position": [0, 0, 1.0]}}}) as sim:
        names = [n for n in sim.world.body_names if n.startswith("ant")]
        assert names[0] == "ant" and len(sim.world.joints("ant")) > 4


def test_missing_sdf_is_a_one_line_error() -> None:
    with pytest.raises(ConfigError, match=r"SDF 'nope/arm.sdf' not found"):
        make_sim({"robots": {"arm": {"sdf": "nope/arm.sdf", "position": [0, 0, 0]}}})


def test_a_body_is_one_kind_of_model() -> None:
    with pytest.raises(ConfigError, match="exactly one of 'shape'.*not urdf and sdf"):
        make_sim({"robots": {"arm": {"urdf": "r2d2.urdf", "sdf": "kuka_iiwa/kuka_with_gripper2.sdf",
                                     "position": [0, 0, 0]}}})


# ----------------------------------------------------------------------------------------- mount
def test_mounted_tool_follows_the_flange() -> None:
    config = {
        "bodies": {"plane": PLANE,
                   "tool": {"shape": "box", "size": [0.04, 0.04, 0.1], "mass": 0.3,
                            "mount": {"body": "kuka", "link": "lbr_iiwa_link_7", "position": [0, 0, 0.08],
                                      "rpy_deg": [0, 0, 30]}}},
        "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "actuators": {"joints": {"type": "joint_control", "body": "kuka"}},
    }
    with make_sim(config) as sim:
        w, c = sim.world, sim.world.client
        flange = w.link("kuka", "lbr_iiwa_link_7")

        def tool_in_flange() -> tuple[np.ndarray, float]:
            fpos, forn = w.pose("kuka", flange)
            inv = c.invertTransform(fpos, forn)
            com, orn = c.getBasePositionAndOrientation(w.body("tool"))
            rel_pos, rel_orn = c.multiplyTransforms(*inv, com, orn)
            return np.array(rel_pos), math.degrees(c.getEulerFromQuaternion(rel_orn)[2])

        start, yaw = tool_in_flange()
        assert start == pytest.approx([0, 0, 0.08], abs=1e-6) and yaw == pytest.approx(30, abs=1e-4)
        sim.components["joints"].command(JointCommand("position", {"lbr_iiwa_joint_2": 0.8, "lbr_iiwa_joint_4": -1.0,
                                                                   "lbr_iiwa_joint_7": 1.0}))
        sim.step(480)
        moved = w.pose("kuka", flange)[0]
        assert math.dist(moved, (0, 0, 1.2)) > 0.2  # the arm really moved
        after, yaw = tool_in_flange()
        assert after == pytest.approx([0, 0, 0.08], abs=2e-3) and yaw == pytest.approx(30, abs=0.5)


def test_mount_on_an_unknown_link_names_the_key() -> None:
    config = {"bodies": {"tool": {"shape": "box", "mount": {"body": "kuka", "link": "flange"}}},
              "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}}}
    with pytest.raises(ConfigError, match=r"bodies\.tool\.mount\.link.*unknown link 'flange'"):
        make_sim(config)


# ----------------------------------------------------------------------------------------- gripper
def _kuka_with_cube(gripper: dict) -> dict:
    return {"bodies": {"plane": PLANE}, "robots": {"kuka": KUKA_SDF}, "actuators": {"gripper": gripper}}


def test_revolute_fingers_open_and_close_by_config() -> None:
    with make_sim(_kuka_with_cube(KUKA_GRIPPER)) as sim:
        g, c, w = sim.components["gripper"], sim.world.client, sim.world
        left, right = (w.joint("kuka", n).index for n in KUKA_GRIPPER["finger_joints"])
        sim.step(60)
        assert sim.readings["gripper"].width == pytest.approx(0.084, abs=2e-3)
        assert c.getJointState(w.body("kuka"), left)[0] == pytest.approx(-0.22, abs=5e-3)
        g.command(GripperCommand("width", width=0.042))
        sim.step(120)
        assert c.getJointState(w.body("kuka"), left)[0] == pytest.approx(-0.085, abs=5e-3)
        assert c.getJointState(w.body("kuka"), right)[0] == pytest.approx(0.085, abs=5e-3)
        g.command(GripperCommand("close"))
        sim.step(120)
        state = sim.readings["gripper"]
        assert state.width < 0.004 and not state.holding  # closed on nothing: empty


def test_a_single_driven_finger_with_a_mimic_follower() -> None:
    gripper = {**KUKA_GRIPPER, "finger_joints": ["base_left_finger_joint"], "open_positions": [-0.22],
               "closed_positions": [0.05], "mimic": {"base_right_finger_joint": -1.0},
               "finger_links": [["left_finger", "left_finger_base", "left_finger_tip"],
                                ["right_finger", "right_finger_base", "right_finger_tip"]]}
    with make_sim(_kuka_with_cube(gripper)) as sim:
        w, c = sim.world, sim.world.client
        kuka = w.body("kuka")
        left, right = w.joint("kuka", "base_left_finger_joint").index, w.joint("kuka", "base_right_finger_joint").index
        sim.components["gripper"].command(GripperCommand("width", width=0.03))
        sim.step(240)
        ql, qr = c.getJointState(kuka, left)[0], c.getJointState(kuka, right)[0]
        assert ql == pytest.approx(-0.22 + (0.03 / 0.084) * 0.0 + (1 - 0.03 / 0.084) * 0.27, abs=0.01)
        assert qr == pytest.approx(-ql, abs=0.01)  # the follower mirrors the driven joint


@pytest.mark.parametrize(("change", "message"), [
    ({"open_positions": [-0.2]}, "'open_positions' needs one value per finger joint"),
    ({"finger_joints": ["base_left_finger_joint"], "open_positions": None, "closed_positions": None},
     "needs 'finger_links'"),
    ({"open_width": None}, "give 'open_width'"),
    ({"finger_joints": ["J0", "gripper_to_arm"], "open_positions": [0.1, 0.1], "closed_positions": [0.1, 0.0]},
     "open and closed positions must differ"),
])
def test_gripper_config_errors_are_one_line(change: dict, message: str) -> None:
    gripper = {k: v for k, v in {**KUKA_GRIPPER, **change}.items() if v is not None}
    with pytest.raises(ConfigError) as err:
        make_sim(_kuka_with_cube(gripper))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_panda_defaults_unchanged() -> None:
    config = {"bodies": {"plane": PLANE},
              "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
              "actuators": {"gripper": {"type": "gripper", "body": "panda"}}}
    with make_sim(config) as sim:
        sim.step(10)
        assert sim.readings["gripper"].width == pytest.approx(0.08, abs=1e-3)  # two prismatic fingers at 0.04


# ----------------------------------------------------------------------------------------- suction
def _suction_scene(cup_z: float) -> dict:
    return {
        "bodies": {"plane": PLANE,
                   "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0, 0, 0.025]},
                   "cup": {"shape": "cylinder", "radius": 0.02, "height": 0.02, "mass": 0, "position": [0, 0, cup_z]}},
        "actuators": {"cup": {"type": "suction", "body": "cup"}},
    }


def test_suction_holds_what_it_touches_and_lets_go() -> None:
    with make_sim(_suction_scene(0.0595)) as sim:  # the cup's face 0.5 mm into the cube's top
        cup, w = sim.components["cup"], sim.world
        cup.command(GripperCommand("close"))
        sim.step(5)
        assert sim.readings["cup"].holding and sim.readings["cup"].held == "cube"
        w.set_pose("cup", (0.1, 0.0, 0.3))  # a static cup teleported: the cube must come along
        sim.step(120)
        assert w.pose("cube")[0][2] > 0.2
        cup.command(GripperCommand("open"))
        sim.step(240)
        assert not sim.readings["cup"].holding and w.pose("cube")[0][2] == pytest.approx(0.025, abs=2e-3)


def test_suction_holds_nothing_out_of_contact() -> None:
    with make_sim(_suction_scene(0.08)) as sim:  # 1 cm above the cube
        sim.components["cup"].command(GripperCommand("close"))
        sim.step(30)
        state = sim.readings["cup"]
        assert not state.holding and state.settled  # settled after settle_time with nothing to hold
        assert sim.world.pose("cube")[0][2] == pytest.approx(0.025, abs=1e-3)


def test_pick_place_with_a_suction_cup_mounted_on_a_kuka() -> None:
    out = run_cli("run", "configs/pick_place_suction.toml", "--seed", "3", "--json")
    result = json.loads(out.stdout)
    assert out.returncode == 0, out.stderr
    assert result["outcome"] == "succeeded" and result["result"]["placement_error"] < 0.005


@pytest.mark.slow
def test_sort_with_the_kuka_and_its_sdf_gripper() -> None:
    out = run_cli("run", "configs/sort_kuka.toml", "--json")
    result = json.loads(out.stdout)
    assert out.returncode == 0, out.stderr
    assert result["result"]["red_sorted"] == 2 and result["result"]["blue_sorted"] == 2


# ----------------------------------------------------------------------------------------- static sensors
def test_lesson04_rays_on_stands() -> None:
    out = run_cli("run", "configs/lesson04_rays.toml", "--json")
    assert out.returncode == 0, out.stderr
    last = json.loads(out.stdout)["result"]["last"]
    assert last["down"]["ranges"] == [pytest.approx(2.0 - 0.5, abs=1e-3)]  # from z = 2 to the box top at 0.5
    fan = last["fan"]["ranges"]
    hits = {i: r for i, r in enumerate(fan) if r is not None}
    # 36 rays 10 degrees apart from -180: the west box face is 3.8 m away at -180 deg (ray 0), the east face
    # 1.8 m at 0 deg (ray 18), the north face 2.8 m at +90 deg (ray 27).
    assert hits == {0: pytest.approx(3.8, abs=1e-3), 18: pytest.approx(1.8, abs=1e-3),
                    27: pytest.approx(2.8, abs=1e-3)}


def test_world_fixed_lidar_refuses_a_robot_mount_too() -> None:
    config = {"bodies": {"plane": PLANE},
              "sensors": {"ray": {"type": "lidar", "position": [0, 0, 1], "robot": "plane", "rays": 1}}}
    with pytest.raises(ConfigError, match="give 'position'.*not both"):
        make_sim(config)


def test_base_is_a_link_name_for_every_body() -> None:
    with make_sim({"bodies": {"plane": PLANE, "box": {"shape": "box", "position": [0, 0, 1]}}}) as sim:
        assert sim.world.link("box", "base") == -1 and sim.world.link("box", "link0") == -1
