"""The numpy-only training example learns ``reach`` (short mode: 10 ARS iterations, seed 0)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

pytest.importorskip("gymnasium")

ROOT = Path(__file__).resolve().parents[1]
SHORT_MODE_SUCCESS = 0.7
"""Stated success rate of the short mode over 20 fresh seeds (measured: see README, 'Learning robots')."""


def load_example():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("ars_reach", ROOT / "examples" / "rl" / "ars_reach.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_ars_short_mode_learns_reach(tmp_path: Path) -> None:
    ars = load_example()
    lines: list[str] = []
    result = ars.train(iterations=10, eval_episodes=20, seed=0, log=lines.append)
    assert len(lines) == 10 and result.env_steps > 0
    assert result.success_rate >= SHORT_MODE_SUCCESS, (result.success_rate, lines)
    path = tmp_path / "p.npz"
    result.policy.save(path)  # the saved file is a runnable policy with its [env] section
    from robokit.gym.policy import LinearPolicy

    loaded = LinearPolicy.load(path)
    assert loaded.env["observations"] == ["task.goal_delta"] and loaded.meta["success_rate"] == result.success_rate
