"""The collectbot of ``configs/patrol_pickup.toml`` on the mujoco engine grips cans, lifts them, carries them and
docks them into the bin, judged by the world: where the cans stand at the end of the run (slow: 400 sim s)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
pytest.importorskip("mujoco")

from robokit.core.simulation import build  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BIN = ((0.7, 3.35), (1.3, 4.0))  # the bin's inside (xy, m), as configs/patrol_pickup.toml builds its walls


@pytest.mark.slow
def test_the_collectbot_docks_cans_into_the_bin_on_mujoco() -> None:
    overrides = {"world.engine": "mujoco", "world.seed": 7}
    with build(ROOT / "configs" / "patrol_pickup.toml", overrides=overrides) as sim:
        world = sim.world
        heights: list[float] = []
        lift = world.joint("robot", "lift").index
        while sim.outcome is None and world.time < 400.0:
            sim.step(24)
            heights.append(world.joint_states(world.body("robot"), [lift])[0][0])
        cans = [world.pose(f"can_{i}")[0] for i in range(4)]
    (x0, y0), (x1, y1) = BIN
    inside = [c for c in cans if x0 <= c[0] <= x1 and y0 <= c[1] <= y1 and c[2] < 0.15]
    assert len(inside) >= 3, f"cans in the bin: {len(inside)} of 4 ({cans})"  # 0 when the lift threw the can
    rises = [b - a for a, b in zip(heights, heights[1:], strict=False)]
    assert max(rises) <= 0.15 * 24 * world.time_step * 1.1  # the lift never outran its 0.15 m/s
