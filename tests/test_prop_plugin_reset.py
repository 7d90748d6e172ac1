"""Every component's reading after ``env.reset(seed)`` is a fresh build's, whatever stopped it before.

robokit.gym's reset promises the start state of a fresh build (docs/gym.md), and each plugin's ``reset()`` says
"the start state". ``tests/test_prop_reset.py`` compares the world and the observation; here a used env's history
also brings every actuator that has one to a protective stop (what a monitor does, and what a gripper's ``stop_on``
does by itself) at a generated step, and then the reset env and a fresh one are compared on what every sensor and
actuator reads, field by field (images pixel by pixel), before and after the same actions.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import Phase, example, given, settings
from hypothesis import strategies as st

pytest.importorskip("gymnasium")  # robokit[gym]; the test extra installs it

import robokit.gym  # noqa: E402

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs" / "gym").glob("*.toml"))


def differences(a: Any, b: Any, where: str) -> list[str]:
    """Where two readings differ: dataclass fields, sequences and arrays compared exactly, item by item."""
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        if type(a) is not type(b):
            return [f"{where}: {type(a).__name__} != {type(b).__name__}"]
        return [d for f in dataclasses.fields(a) for d in differences(getattr(a, f.name), getattr(b, f.name),
                                                                      f"{where}.{f.name}")]
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return [] if np.array_equal(np.asarray(a), np.asarray(b)) else [f"{where}: arrays differ"]
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{where}[{i}]")]
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return [f"{where}: keys differ"]
        return [d for k in a for d in differences(a[k], b[k], f"{where}.{k}")]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


def readings(env: Any) -> dict[str, Any]:
    return {name: comp.read() for name, comp in env.sim.components.items()}


@pytest.mark.slow  # two gym envs an example
@pytest.mark.parametrize("config", CONFIGS, ids=lambda p: p.stem)
@settings(max_examples=3, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate])
@example(steps=3, stop_at=20, seed=1, action_seed=2)  # stopped in the episode's last tick, then reset
@given(steps=st.integers(1, 20), stop_at=st.integers(0, 20), seed=st.integers(0, 2**16),
       action_seed=st.integers(0, 2**16))
def test_every_reading_after_a_reset_is_a_fresh_builds(config: Path, steps: int, stop_at: int, seed: int,
                                                       action_seed: int) -> None:
    used, fresh = robokit.gym.make(config), robokit.gym.make(config)
    try:
        used.reset(seed=seed + 1)
        rng = np.random.default_rng(action_seed)
        stoppable = [c for c in used.sim.components.values() if hasattr(c, "protective_stop")]
        for k in range(steps + 1):
            if k == min(stop_at, steps):  # at or after the last step: an action's command would lift the stop
                for comp in stoppable:
                    comp.protective_stop("a test")
            if k < steps:
                used.step(rng.uniform(-1, 1, used.action_space.shape).astype(np.float32))
        used.reset(seed=seed)
        fresh.reset(seed=seed)
        assert differences(readings(used), readings(fresh), "reset") == []
        rng = np.random.default_rng(action_seed + 1)
        for k in range(6):
            act = rng.uniform(-1, 1, used.action_space.shape).astype(np.float32)
            a, b = used.step(act), fresh.step(act)
            assert differences(readings(used), readings(fresh), f"step {k + 1}") == []
            if a[2] or a[3] or b[2] or b[3]:
                break
    finally:
        used.close()
        fresh.close()
