"""robokit.gym: configs as Gymnasium environments — conformance, seeded determinism, reset, render, close."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")  # robokit[gym]; the test extra installs it

import robokit.gym  # noqa: E402
from robokit.errors import ConfigError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ENV_CONFIGS = sorted((ROOT / "configs" / "gym").glob("*.toml"))


def actions(env, n: int, seed: int = 7) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1, 1, env.action_space.shape).astype(np.float32) for _ in range(n)]


def trajectory(env, seed: int, acts: list[np.ndarray]) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    out = [np.concatenate([np.ravel(v) for v in obs.values()]) if isinstance(obs, dict) else obs]
    for a in acts:
        obs, reward, terminated, truncated, _ = env.step(a)
        out.append(np.concatenate([np.ravel(v) for v in obs.values()]) if isinstance(obs, dict) else obs)
        out.append(np.array([reward], np.float32))
        if terminated or truncated:
            break
    return out


@pytest.mark.parametrize("config", ENV_CONFIGS, ids=lambda p: p.stem)
def test_check_env_passes(config: Path) -> None:
    from gymnasium.utils.env_checker import check_env

    env = robokit.gym.make(config)
    check_env(env, skip_render_check=True)
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("config", ENV_CONFIGS, ids=lambda p: p.stem)
def test_same_seed_same_episode_after_other_episodes(config: Path) -> None:
    """A fresh env and one that ran other episodes first give bit-identical observations for the same seed."""
    fresh = robokit.gym.make(config)
    used = robokit.gym.make(config)
    acts = actions(fresh, 30)
    for seed in (11, 12):
        trajectory(used, seed, actions(used, 30, seed=seed))
    a, b = trajectory(fresh, 5, acts), trajectory(used, 5, acts)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    c = trajectory(fresh, 6, acts)
    assert not np.array_equal(a[0], c[0])  # another seed is another episode
    fresh.close()
    used.close()


SCRIPT = """
import json, sys
import numpy as np
import robokit.gym
env = robokit.gym.make(sys.argv[1])
rng = np.random.default_rng(7)
obs, _ = env.reset(seed=5)
rows = [obs.tolist()]
for _ in range(20):
    obs, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
    rows.append(obs.tolist())
print(json.dumps(rows))
"""


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_same_seed_same_observations_across_processes() -> None:
    config = str(ROOT / "configs" / "gym" / "reach.toml")
    runs = [subprocess.run([sys.executable, "-c", SCRIPT, config], capture_output=True, text=True, check=True)
            for _ in range(2)]
    first, second = (json.loads(r.stdout.strip().splitlines()[-1]) for r in runs)
    assert first == second and len(first) == 21
    env = robokit.gym.make(config)  # and the same as in this process
    obs, _ = env.reset(seed=5)
    assert obs.tolist() == first[0]
    env.close()


def test_gymnasium_make_render_and_close_twice() -> None:
    env = gymnasium.make(robokit.gym.ENV_ID, config=str(ROOT / "configs" / "gym" / "reach.toml"),
                         render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (240, 320, 3) and frame.dtype == np.uint8 and frame.std() > 5
    env.close()
    env.close()


def test_reach_succeeds_under_a_proportional_controller() -> None:
    """The task is solvable as declared: steering the end effector at the goal reaches it in every episode."""
    env = robokit.gym.make(ROOT / "configs" / "gym" / "reach.toml")
    for seed in range(5):
        obs, info = env.reset(seed=seed)
        steps, done = 0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(np.clip((obs[6:9] - obs[0:3]) / 0.05, -1, 1))
            steps, done = steps + 1, terminated or truncated
        assert terminated and info["is_success"] and info["distance"] < 0.05 and steps < 25
    env.close()


def test_env_config_errors_are_one_line(tmp_path: Path) -> None:
    text = (ROOT / "configs" / "gym" / "reach.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('type = "reach"', 'type = "reech"'))
    with pytest.raises(ConfigError, match=r"bad.toml: env.task.type: .*'reech'.*reach"):
        robokit.gym.make(bad)
    bad.write_text(text.replace('"arm.velocity"', '"arm.velocityy"'))
    with pytest.raises(ConfigError, match=r"bad.toml: env.observations: 'arm.velocityy': no field 'velocityy'"):
        robokit.gym.make(bad)


@pytest.mark.parametrize("vector", ["sync", "async"])
def test_vector_envs_match_single_envs(vector: str) -> None:
    """Each worker builds its own World; sub-env i with seed s sees what a single env with seed s sees."""
    from functools import partial

    from gymnasium.vector import AsyncVectorEnv, SyncVectorEnv

    config = str(ROOT / "configs" / "gym" / "reach.toml")
    cls = SyncVectorEnv if vector == "sync" else AsyncVectorEnv
    venv = cls([partial(robokit.gym.make, config) for _ in range(2)])
    single = robokit.gym.make(config)
    acts = actions(single, 5)
    obs, _ = venv.reset(seed=[3, 4])
    expected = [trajectory(single, s, acts) for s in (3, 4)]
    assert np.array_equal(obs[0], expected[0][0]) and np.array_equal(obs[1], expected[1][0])
    for k, a in enumerate(acts):
        obs, rewards, *_ = venv.step(np.stack([a, a]))
        for i in range(2):
            assert np.array_equal(obs[i], expected[i][1 + 2 * k])
            assert rewards[i] == pytest.approx(float(expected[i][2 + 2 * k][0]))
    venv.close()
    single.close()


def test_dict_observations_for_goal_conditioned_learning() -> None:
    from gymnasium import spaces
    from gymnasium.utils.env_checker import check_env

    groups = {"observation": ["arm.position", "arm.velocity"], "achieved_goal": "task.achieved",
              "desired_goal": "task.goal"}
    env = robokit.gym.make(ROOT / "configs" / "gym" / "reach.toml", env__observations=groups)
    assert isinstance(env.observation_space, spaces.Dict)
    assert {k: s.shape for k, s in env.observation_space.spaces.items()} == {
        "observation": (6,), "achieved_goal": (3,), "desired_goal": (3,)}
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=1)
    assert np.allclose(np.linalg.norm(obs["desired_goal"] - obs["achieved_goal"]), info["distance"], atol=1e-6)
    env.close()


KUKA_ENV = {
    "world": {"time_step": 1 / 240},
    "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {
        "joints": {"type": "joint_control", "body": "kuka", "joints": ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2"]},
        "ee": {"type": "ee_delta", "body": "kuka", "ee_link": "lbr_iiwa_link_7"},
    },
    "env": {
        "control_hz": 24,
        "observations": ["joints.positions", "ee.position", "task.goal"],
        "actions": {"joints": {"kind": "joint_targets", "joints": ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2"],
                               "low": [-1.0, -0.5], "high": [1.0, 0.5]}},
        "task": {"type": "reach", "ee": "ee", "goal_low": [0.3, -0.3, 0.6], "goal_high": [0.5, 0.3, 1.0],
                 "max_time": 1.0},
    },
}


def test_joint_target_actions_drive_named_joints() -> None:
    """``joint_targets``: -1..1 maps to each joint's low..high; the joints get there under position control."""
    env = robokit.gym.make(KUKA_ENV)
    assert env.action_space.shape == (2,) and env.observation_space.shape == (2 + 3 + 3,)
    obs, _ = env.reset(seed=0)
    for _ in range(24):
        obs, *_ = env.step(np.array([0.5, -1.0], np.float32))
    assert obs[0] == pytest.approx(0.5, abs=0.02) and obs[1] == pytest.approx(-0.5, abs=0.02)
    env.close()
