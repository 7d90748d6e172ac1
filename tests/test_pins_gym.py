"""robokit.gym promises, each computed from the task's definition or the action spec (not from a second run of the
env): dense and sparse rewards, the goal in the robot's frame, goals at least min_distance away, truncation at
exactly max_time, termination on a task failure, action clipping and scaling, the arm's floor and step limit."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")  # robokit[gym]; the test extra installs it

import robokit.gym  # noqa: E402
from robokit.msgs import EEDelta, Twist  # noqa: E402

GYM = Path(__file__).resolve().parents[1] / "configs" / "gym"


def go_to(**overrides: object):  # type: ignore[no-untyped-def]
    return robokit.gym.make(GYM / "go_to.toml", env__observations=["drive.pose", "task.goal_in_robot_frame"],
                            **overrides)


def pose_and_goal(env) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    task = env.unwrapped.task
    return np.asarray(env.unwrapped.sim.readings["drive"].pose), np.asarray(task.goal)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_go_to_dense_reward_is_minus_the_distance_and_the_goal_is_seen_in_the_robots_frame(seed: int) -> None:
    env = go_to()
    env.reset(seed=seed)
    obs, reward, *_ = env.step(np.array([0.6, 0.8], np.float32))
    (x, y, yaw), goal = pose_and_goal(env)
    dx, dy = goal[0] - x, goal[1] - y
    assert reward == pytest.approx(-math.hypot(dx, dy), abs=1e-6)
    forward = math.cos(yaw) * dx + math.sin(yaw) * dy  # the goal rotated by -yaw
    left = -math.sin(yaw) * dx + math.cos(yaw) * dy
    assert obs[3:5] == pytest.approx([forward, left], abs=1e-5)
    env.close()


@pytest.mark.parametrize("seed", range(12))
def test_goals_are_drawn_at_least_min_distance_from_the_robot(seed: int) -> None:
    env = go_to()
    env.reset(seed=seed)
    (x, y, _), goal = pose_and_goal(env)
    assert math.hypot(goal[0] - x, goal[1] - y) >= 0.5  # min_distance
    assert -1.5 <= goal[0] <= 1.5 and -1.5 <= goal[1] <= 1.5
    env.close()


def test_truncated_exactly_at_max_time_and_info_counts_sim_seconds() -> None:
    """10 Hz control, max_time 3 s: standing still, step 30 is the first truncated one, at sim_time 3.0."""
    env = go_to(env__task__max_time=3.0)
    env.reset(seed=0)
    for k in range(1, 31):
        _, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
        assert info["sim_time"] == pytest.approx(k / 10)
        assert not terminated
        assert truncated == (k == 30), k
    env.close()


def test_clipped_actions_scale_to_max_speed_and_max_turn_rate() -> None:
    env = go_to()
    env.reset(seed=0)
    env.step(np.array([5.0, -3.0], np.float32))
    assert env.unwrapped.sim.components["drive"].cmd == Twist(0.5, -2.0)  # clipped to [1, -1] first
    env.step(np.array([0.5, 0.25], np.float32))
    assert env.unwrapped.sim.components["drive"].cmd == Twist(0.25, 0.5)
    env.close()


def test_joint_target_actions_map_minus_one_to_one_onto_low_to_high() -> None:
    env = go_to(robots__kuka={"urdf": "kuka_iiwa/model.urdf", "position": [3, 3, 0], "fixed_base": True},
                actuators__pid={"type": "pid", "body": "kuka", "joints": {"lbr_iiwa_joint_1": {"kp": 10.0}}},
                env__actions__pid={"kind": "joint_targets", "joints": ["lbr_iiwa_joint_1"], "low": [-0.4],
                                   "high": [1.2]})
    env.reset(seed=0)
    pid = env.unwrapped.sim.components["pid"]
    for a, want in [(-1.0, -0.4), (1.0, 1.2), (0.0, 0.4), (0.5, 0.8)]:
        env.step(np.array([0.0, 0.0, a], np.float32))
        assert pid.setpoint[0] == pytest.approx(want)
    env.close()


def test_gripper_actions_map_onto_zero_to_max_width() -> None:
    env = robokit.gym.make(GYM / "pick.toml")
    env.reset(seed=0)
    for a, want in [(-1.0, 0.0), (1.0, 0.08), (0.0, 0.04)]:
        env.step(np.array([0.0, 0.0, 0.0, a], np.float32))
        cmd = env.unwrapped.sim.components["gripper"]
        assert isinstance(cmd.target, float) and cmd.target == pytest.approx(want)
    env.close()


@pytest.mark.parametrize(("threshold", "reward"), [(0.001, -1.0), (10.0, 0.0)])
def test_reach_sparse_reward_is_0_on_success_and_minus_1_otherwise(threshold: float, reward: float) -> None:
    env = robokit.gym.make(GYM / "reach.toml", env__task__reward="sparse", env__task__distance_threshold=threshold)
    env.reset(seed=0)
    _, r, terminated, _, info = env.step(np.zeros(env.action_space.shape, np.float32))
    assert r == reward and info["is_success"] == (reward == 0.0) and terminated == (reward == 0.0)
    env.close()


def test_a_task_failure_terminates_the_episode_and_is_reported() -> None:
    """push: the cube pushed off the table (below fall_height) ends the episode as failed; on the table it does
    not."""
    env = robokit.gym.make(GYM / "push.toml")
    env.reset(seed=0)
    _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
    assert not terminated and "failure" not in info
    env.unwrapped.sim.world.set_pose("cube", (0.3, 0.6, -0.3))  # beside the table, falling
    _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
    assert terminated and not truncated and "fell" in info["failure"]
    env.close()


def test_ee_delta_keeps_min_height_and_clamps_long_steps() -> None:
    with robokit.gym.make(GYM / "pick.toml", actuators__arm__min_height=0.12).unwrapped as env:
        env.reset(seed=0)
        sim = env.sim
        arm = sim.components["arm"]
        for _ in range(12):  # push straight down, 5 cm a step
            arm.command(EEDelta((0.0, 0.0, -0.3)))
            sim.step(20)
        assert sim.readings["arm"].position[2] >= 0.12 - 0.01
        before = np.asarray(sim.readings["arm"].position)
        arm.command(EEDelta((0.0, 0.3, 0.0)))  # 0.3 m asked, max_step 0.1 m
        sim.step(120)
        moved = np.asarray(sim.readings["arm"].position) - before
        assert moved[1] == pytest.approx(0.1, abs=0.02)
