"""Training with stable-baselines3 (``robokit[rl]``; .ci/run's slow tier installs torch and the extra):
``python -m robokit.gym.train`` learns reach with PPO and writes a policy that ``robokit run`` runs unedited; SB3's
HerReplayBuffer trains on ``gymnasium.make("robokit/Reach-v0", goal_env=True)``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # every test here trains; the extra is installed by .ci/run's slow tier only

ROOT = Path(__file__).resolve().parents[1]
REACH = ROOT / "configs" / "gym" / "reach.toml"
PPO_TIMESTEPS = 40_000
"""PPO on reach, seed 0, 2 envs: over 90 % of the last 100 training episodes by ~18k steps, 100 % at 40k."""


@pytest.mark.slow
@pytest.mark.timeout(1800)  # ~2 min on a quiet machine; 10 min seen at load 12
def test_ppo_learns_reach_and_the_saved_policy_runs_as_a_behaviour(tmp_path: Path) -> None:
    from robokit.testing import make_sim

    run = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "robokit.gym.train", str(REACH), "--algo", "ppo", "--timesteps",
                           str(PPO_TIMESTEPS), "--seed", "0", "--envs", "2", "--out", str(run)],
                          capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = [json.loads(line) for line in (run / "progress.jsonl").read_text().splitlines()]
    summary = lines[-1]["summary"]
    assert summary["eval_episodes"] == 100 and summary["eval_success_rate"] >= 0.9, summary
    steps = [line["env_steps"] for line in lines[:-1]]
    assert steps == sorted(steps) and steps[-1] == summary["env_steps"] >= PPO_TIMESTEPS
    assert lines[-2]["success_rate"] >= 0.9 and lines[-2]["episodes"] > lines[0]["episodes"] > 0
    assert list((run / "tb").rglob("events.out.tfevents.*")), "no TensorBoard file"
    toml = (run / "policy.toml").read_text()
    assert toml.startswith("# Written by python -m robokit.gym.train") and 'policy = "policy.zip"' in toml
    # the policy config as written, not edited: the behaviour (not the env) reaches the goal on fresh seeds
    successes = 0
    for seed in range(100, 120):
        with make_sim(run / "policy.toml", seed=seed) as sim:
            result = sim.run()
        assert result.result["policy"]["algorithm"] == "PPO"
        successes += result.outcome == "succeeded" and result.result["distance"] < 0.05
    assert successes >= 18, successes
    cli = subprocess.run([sys.executable, "-m", "robokit.cli", "run", str(run / "policy.toml"), "--seed", "7"],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert cli.returncode == 0 and "outcome: succeeded" in cli.stdout, cli.stdout + cli.stderr


@pytest.mark.slow
def test_her_replay_buffer_trains_on_the_goal_env() -> None:
    """SAC + HerReplayBuffer on the registered id: relabelled samples carry the reward of their new goal."""
    import gymnasium
    import torch
    from stable_baselines3 import SAC, HerReplayBuffer

    torch.set_num_threads(1)
    import robokit.gym  # noqa: F401 - registers robokit/Reach-v0

    env = gymnasium.make("robokit/Reach-v0", goal_env=True)
    model = SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
                learning_starts=500, batch_size=128, seed=0, device="cpu")
    model.learn(total_timesteps=2000)
    assert model.num_timesteps == 2000 and model.replay_buffer.size() == 2000
    batch = model.replay_buffer.sample(1024)  # relabels with the env's compute_reward
    achieved = batch.next_observations["achieved_goal"].numpy()
    desired = batch.observations["desired_goal"].numpy()
    by_hand = np.where(np.linalg.norm(achieved - desired, axis=1) < 0.05, 0.0, -1.0)
    assert np.array_equal(batch.rewards.numpy().ravel(), by_hand)
    assert (by_hand == 0.0).mean() > 0.2  # relabelling turned failures into successes
    env.close()


@pytest.mark.slow
def test_train_cli_mistakes_are_one_line(tmp_path: Path) -> None:
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "robokit.gym.train", *args, "--out", str(tmp_path / "r")],
                              capture_output=True, text=True, timeout=120)

    bad = run(str(REACH), "--algo", "ppo", "--her")
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "train: error: --her needs an off-policy algorithm (--algo sac or td3)"]
    bad = run(str(tmp_path / "nope.toml"))
    assert bad.returncode == 2 and "not found" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    bad = run(str(REACH), "--set", "world.time_step=0.01")
    assert bad.returncode == 2 and "only the [env] section" in bad.stderr


@pytest.mark.slow
def test_a_goal_env_policy_runs_as_a_behaviour(tmp_path: Path) -> None:
    """SAC + HER through the command (a short run): the Dict-observation policy drives a robokit run, whose
    result names the method; the [env] section in the .zip says goal_env."""
    import zipfile

    from robokit.testing import make_sim

    run = tmp_path / "her"
    proc = subprocess.run([sys.executable, "-m", "robokit.gym.train", str(REACH), "--algo", "sac", "--her",
                           "--goal-env", "--timesteps", "400", "--learning-starts", "200", "--envs", "1",
                           "--eval-episodes", "2", "--out", str(run)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    with zipfile.ZipFile(run / "policy.zip") as archive:
        carried = json.loads(archive.read("robokit_env.json"))
    assert carried["env"]["goal_env"] is True and carried["env"]["task"]["reward"] == "sparse"
    with make_sim(run / "policy.toml", seed=5) as sim:
        result = sim.run()
    assert result.outcome in ("succeeded", "failed") and result.result["steps"] >= 1
    assert result.result["policy"]["method"] == "stable-baselines3 SAC + HER"
