"""Devices on the mujoco engine, each against an expectation worked out by hand: a contact sensor weighs a resting
box, a lidar measures the distance to a wall, the diff drive rolls the diffbot, and the Panda picks and places a
cube the same way twice."""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
pytest.importorskip("mujoco")

from robokit.core.simulation import build  # noqa: E402
from robokit.msgs import Twist  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PLANE = {"urdf": "plane.urdf", "position": [0, 0, 0]}


def test_a_contact_sensor_weighs_a_box_resting_on_the_floor() -> None:
    scene = {"world": {"engine": "mujoco"},
             "bodies": {"plane": PLANE,
                        "crate": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 2.0, "position": [0, 0, 0.1]}},
             "sensors": {"touch": {"type": "contact", "body": "crate"}}}
    with build(scene) as sim:
        sim.step(240)
        state = sim.components["touch"].read()
    assert state.in_contact and state.others == ("plane",)
    assert state.normal_force == pytest.approx(2.0 * 9.81, rel=0.02)  # the floor carries the box's weight


def test_a_lidar_measures_the_distance_to_a_wall() -> None:
    scene = {"world": {"engine": "mujoco"},
             "bodies": {"plane": PLANE,
                        "wall": {"shape": "box", "size": [0.1, 4.0, 0.5], "mass": 0, "position": [2.0, 0, 0.25]}},
             "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
             "sensors": {"scan": {"type": "lidar", "robot": "robot", "link": "lidar_link", "rays": 8,
                                  "range_max": 3.0}}}
    with build(scene) as sim:
        sim.step(2)
        origin = sim.world.pose("robot", sim.world.link("robot", "lidar_link"))[0]
        scan = sim.components["scan"].read()
    ahead = [i for i in range(8) if abs(scan.angle_min + i * scan.angle_increment) < 1e-9][0]
    assert scan.ranges[ahead] == pytest.approx(1.95 - origin[0], abs=0.005)  # the wall's near face is at x = 1.95
    behind = [i for i in range(8) if abs(abs(scan.angle_min + i * scan.angle_increment) - math.pi) < 1e-9][0]
    assert math.isinf(scan.ranges[behind])  # nothing within 3 m behind the robot


def test_the_diff_drive_rolls_the_diffbot_forward() -> None:
    scene = {"world": {"engine": "mujoco"}, "bodies": {"plane": PLANE},
             "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
             "actuators": {"drive": {"type": "diff_drive", "left_wheels": ["left_wheel"],
                                     "right_wheels": ["right_wheel"], "wheel_radius": 0.05, "track_width": 0.26}}}
    with build(scene) as sim:
        sim.step(10)
        sim.components["drive"].command(Twist(0.2, 0.0))
        sim.step(2 * 240)
        (x, y, _), _ = sim.world.pose("robot")
    assert 0.25 < x < 0.4  # 0.2 m/s for 2 s, less the ramp up
    assert abs(y) < 0.03


def test_the_panda_picks_and_places_a_cube_the_same_way_twice() -> None:
    results = []
    for _ in range(2):
        with build(ROOT / "configs" / "pick_place.toml", overrides={"world.engine": "mujoco"}) as sim:
            out = sim.run()
        assert out.outcome == "succeeded", out.reason
        results.append(out.result)
    assert results[0] == results[1]
    assert results[0]["placement_error"] < 0.02  # the cube rests within 2 cm of the place position


def test_a_held_cube_moves_with_the_hand_during_the_transport() -> None:
    """The cube's position in the hand's frame, read from the world every 4 ticks while it is off the table (its
    centre 2 cm above its resting height), stays within 2.5 mm of where it was once the grip settled (40 ticks
    after lift-off). Over 20 seeds the drift was at most 2.0 mm; before the engine's grasp settings, 9-17 mm."""
    with build(ROOT / "configs" / "pick_place.toml", overrides={"world.engine": "mujoco", "world.seed": 7}) as sim:
        world = sim.world
        hand = {j.child_link: j.index for j in world.joints("panda")}["panda_hand"]
        offsets = []
        for _ in range(round(2.5 / world.time_step / 4)):
            sim.step(4)
            cube = world.pose("cube")
            if cube[0][2] > 0.045:
                inverse = world.invert_transform(*world.pose("panda", hand))
                offsets.append(world.multiply_transforms(*inverse, *cube)[0])
        assert len(offsets) * 4 * world.time_step > 0.5  # a transport of more than 0.5 s was watched
        settled = offsets[10]
        drift = max(math.dist(settled, o) for o in offsets[10:])
        assert drift < 0.0025, f"the cube moved {drift * 1000:.1f} mm in the hand"


def test_a_wrist_force_torque_sensor_weighs_the_hand() -> None:
    scene = {"world": {"engine": "mujoco"},
             "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
             "sensors": {"ft": {"type": "force_torque", "body": "panda", "joint": "panda_hand_joint",
                                "world_frame": True}}}
    with build(scene) as sim:
        world = sim.world
        arm = world.body("panda")
        for joint in [j.index for j in world.joints(arm) if j.movable]:  # hold the arm still
            world.set_joint_motor(arm, joint, "position", target_position=0.0, force=500.0)
        sim.step(480)
        carried = sum(world.mass(arm, world.link(arm, name))
                      for name in ("panda_hand", "panda_leftfinger", "panda_rightfinger"))
        wrench = sim.components["ft"].read()
    assert wrench.force[2] == pytest.approx(carried * 9.81, rel=0.01)  # the arm holds the hand up against gravity
    assert abs(wrench.force[0]) < 0.01 and abs(wrench.force[1]) < 0.01


def test_randomize_scales_masses_and_friction_on_mujoco() -> None:
    raw = {"world": {"engine": "mujoco"},
           "bodies": {"plane": PLANE, "cube": {"shape": "box", "mass": 0.1, "position": [0, 0, 0.05]}},
           "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [1, 0, 0], "fixed_base": True}},
           "actuators": {"gripper": {"type": "gripper", "body": "panda"}},
           "randomize": {"friction_scale": [0.5, 0.5], "mass_scale": [2.0, 2.0]}}
    with build(raw) as sim:
        world = sim.world
        finger = world.dynamics("panda", world.link("panda", "panda_leftfinger"))
        assert world.mass("cube") == pytest.approx(0.2)  # 0.1 kg times 2
        assert finger["mass"] == pytest.approx(0.2)  # the URDF's 0.1 kg times 2
        assert finger["lateral_friction"] == pytest.approx(0.6)  # the gripper's 1.2 times 0.5


def test_a_gym_env_on_mujoco_passes_check_env_and_replays_a_seed() -> None:
    pytest.importorskip("gymnasium")
    import numpy as np
    from gymnasium.utils.env_checker import check_env

    import robokit.gym

    env = robokit.gym.make(ROOT / "configs" / "gym" / "reach.toml", world__engine="mujoco")
    try:
        assert env.world.engine == "mujoco"
        check_env(env, skip_render_check=True)
        episodes = []
        for _ in range(2):
            obs, _ = env.reset(seed=3)
            actions = np.random.default_rng(0).uniform(-1, 1, (20, *env.action_space.shape))
            seen = [np.ravel(obs)]
            for action in actions.astype(env.action_space.dtype):
                obs, reward, *_ = env.step(action)
                seen += [np.ravel(obs), np.array([reward])]
            episodes.append(np.concatenate(seen))
        assert episodes[0].tobytes() == episodes[1].tobytes()
    finally:
        env.close()


TWO_BODIES = """<mujoco><worldbody>
  <body name="stand" pos="0 0 1"><geom type="box" size="0.05 0.05 0.05" mass="0"/>
    <body name="arm"><joint name="swing" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="0.5"/></body></body>
  <body name="ball" pos="1 0 0.5"><freejoint/><geom type="sphere" size="0.05" mass="0.2"/></body>
</worldbody></mujoco>"""


def test_an_mjcf_file_loads_as_bodies_placed_as_the_file_places_them(tmp_path: Path) -> None:
    (tmp_path / "two.xml").write_text(TWO_BODIES)
    scene = {"world": {"engine": "mujoco"},
             "bodies": {"plane": PLANE, "rig": {"mjcf": "two.xml", "position": [0, 0, 0.5]}}}
    with build(scene, base_dir=tmp_path) as sim:
        world = sim.world
        assert world.body_names == ["plane", "rig", "rig_1"]
        assert world.pose("rig")[0] == pytest.approx((0, 0, 0.5))  # the first base where the config puts it
        assert world.pose("rig_1")[0] == pytest.approx((1, 0, 0.0))  # the second kept 0.5 m below the first
        assert [(j.name, j.type) for j in world.joints("rig")] == [("swing", "revolute")]
        sim.step(240)
        assert world.pose("rig_1")[0][2] == pytest.approx(0.05, abs=0.005)  # the ball rests on the floor
        assert abs(world.joint_states(world.body("rig"), [0])[0].position) > 0.5  # the arm swung down


def test_a_plugin_that_reaches_for_pybullet_is_told_so_on_mujoco() -> None:
    with build({"world": {"engine": "mujoco"}, "bodies": {"plane": PLANE}}) as sim:
        assert sim.world.client.model.nbody == 2  # MuJoCo's own handle, for engine-aware tools
        with pytest.raises(AttributeError, match=r"world.client.getContactPoints is a PyBullet call"):
            sim.world.client.getContactPoints()


def test_the_patrol_robot_reruns_identically_on_mujoco() -> None:
    runs = []
    for _ in range(2):
        with build(ROOT / "configs" / "patrol_robot.toml", overrides={"world.engine": "mujoco"}, seed=4) as sim:
            out = sim.run(max_time=8.0)
            runs.append((out.result, sim.world.pose("robot"), sim.world.tick))
    assert runs[0] == runs[1]
    assert runs[0][0]["distance_travelled"] > 1.0  # it did drive


def test_a_position_motor_keeps_to_its_velocity_cap_and_still_squeezes_when_held_back() -> None:
    """The collectbot's lift (a prismatic joint) sent 0.15 m up at 0.15 m/s rises at that speed, read from the world
    tick by tick, not in one jump; its fingers closed on a can at 0.1 m/s stop on it and press it from both sides."""
    scene = {"world": {"engine": "mujoco"},
             "bodies": {"plane": PLANE,
                        "can": {"shape": "cylinder", "radius": 0.05, "height": 0.2, "mass": 0.2,
                                "position": [3.0, 0, 0.1]}},
             "robots": {"robot": {"urdf": "robots/collectbot.urdf", "position": [0, 0, 0.06]}}}
    with build(scene) as sim:
        world = sim.world
        robot = world.body("robot")
        lift, left, right = (world.joint(robot, name).index for name in ("lift", "left_finger", "right_finger"))
        for finger in (left, right):
            world.set_joint_motor(robot, finger, "position", target_position=0.06, force=15.0)
        sim.step(120)
        (lx, ly, _), _ = world.pose(robot, left)
        (rx, ry, _), _ = world.pose(robot, right)
        world.set_pose("can", [(lx + rx) / 2 + 0.07, (ly + ry) / 2, 0.1])  # between the open fingers
        for finger in (left, right):
            world.set_joint_motor(robot, finger, "position", target_position=0.0, force=15.0, max_velocity=0.1)
        sim.step(round(0.8 / world.time_step))
        fingers = [s[0] for s in world.joint_states(robot, [left, right])]
        squeeze = sum(c.normal_force for c in world.contacts(robot, world.body("can")))
        start = world.joint_states(robot, [lift])[0][0]
        world.set_joint_motor(robot, lift, "position", target_position=0.15, force=30.0, max_velocity=0.15)
        heights = []
        for _ in range(round(0.5 / world.time_step)):
            sim.step(1)
            heights.append(world.joint_states(robot, [lift])[0][0])
    speeds = [(b - a) / world.time_step for a, b in zip([start, *heights], heights, strict=False)]
    assert max(speeds) < 0.15 * 1.1  # never faster than the cap (uncapped, the lift jumped 4 cm in 6 ticks)
    assert heights[-1] - start == pytest.approx(0.15 * 0.5, abs=0.01)  # 0.5 s at 0.15 m/s, less the start
    assert all(0.0 < f < 0.06 for f in fingers)  # stopped on the can, not closed
    assert squeeze > 2.0  # both fingers press on it (N)
