"""The ``policy`` behaviour: a saved policy drives the same actuators from the same observations in a robokit run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")

ROOT = Path(__file__).resolve().parents[1]


def p_controller(config: Path, tmp_path: Path) -> Path:
    """A linear policy file that steers the end effector straight at the goal (what a trained one approximates)."""
    from robokit.config import read_toml
    from robokit.gym.policy import LinearPolicy

    W = np.zeros((3, 9))
    W[:, 0:3], W[:, 6:9] = -20.0 * np.eye(3), 20.0 * np.eye(3)
    policy = LinearPolicy(W, np.zeros(3), np.zeros(9), np.ones(9), env=read_toml(config)["env"], meta={"by": "hand"})
    path = tmp_path / "p.npz"
    policy.save(path)
    return path


def test_policy_behaviour_runs_a_saved_policy(tmp_path: Path) -> None:
    from robokit.gym.policy import LinearPolicy
    from robokit.testing import make_sim

    path = p_controller(ROOT / "configs" / "gym" / "reach.toml", tmp_path)
    loaded = LinearPolicy.load(path)
    assert loaded.meta == {"by": "hand"} and loaded.env["task"]["type"] == "reach"
    for seed in (1, 2):
        with make_sim(ROOT / "configs" / "reach_policy.toml", seed=seed,
                      overrides={"behaviour.policy": str(path)}) as sim:
            result = sim.run()
        assert result.outcome == "succeeded", result.reason
        assert result.result["distance"] < 0.05 and 1 <= result.result["steps"] < 25


def test_policy_behaviour_errors_are_config_errors(tmp_path: Path) -> None:
    from robokit.testing import edited_config, validate_error

    missing = edited_config(ROOT / "configs" / "reach_policy.toml", tmp_path, "policies/reach_linear.npz",
                            "policies/nope.npz")
    assert "behaviour.policy: policy file" in validate_error(missing)


def test_the_committed_reach_policy_succeeds() -> None:
    """configs/policies/reach_linear.npz (examples/rl/ars_reach.py, full run) reaches the goal on fresh seeds."""
    from robokit.testing import make_sim

    for seed in range(20, 25):
        with make_sim(ROOT / "configs" / "reach_policy.toml", seed=seed) as sim:
            result = sim.run()
        assert result.outcome == "succeeded", (seed, result.reason)
        assert result.result["policy"]["method"] == "ARS V2-t" and result.result["distance"] < 0.05
