"""Grasps on MuJoCo (robokit/engines/mujoco/grip.py): a cube the Panda squeezes moves with the hand while it is
carried (within 1 mm of where it settled in the fingers), and is put down where it was asked. Real physics; the
oracle is the world's poses."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from robokit.config import load_config
from robokit.core.simulation import Simulation
from robokit.plugin_api.plugins import load_plugins

PICK_PLACE = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"


@pytest.fixture(scope="module")
def plugins():  # type: ignore[no-untyped-def]
    return load_plugins()


def carried(plugins: Any, overrides: dict[str, Any]) -> tuple[Any, list[tuple[float, float, float]], float]:
    """Run pick_place on MuJoCo; the cube's offsets in the hand's frame while it is 2 cm or more above where it
    rested (every 4 ticks), and the highest it got (m)."""
    cfg = load_config(PICK_PLACE, plugins, {"world.engine": "mujoco", **overrides})
    with Simulation(cfg, plugins) as sim:
        world = sim.world
        hand = {j.child_link: j.index for j in world.joints("panda")}["panda_hand"]
        rest = world.pose("cube")[0][2]
        offsets, top = [], rest
        step = world.step

        def watched() -> None:
            nonlocal top
            step()
            pose = world.pose("cube")
            top = max(top, pose[0][2])
            if world.tick % 4 == 0 and pose[0][2] > rest + 0.02:
                inverse = world.invert_transform(*world.pose("panda", hand))
                offsets.append(world.multiply_transforms(*inverse, *pose)[0])

        world.step = watched  # type: ignore[method-assign]
        out = sim.run()
    return out, offsets, top - rest


def test_a_squeezed_cube_moves_with_the_hand(plugins: Any) -> None:
    out, offsets, _ = carried(plugins, {"world.seed": 207})
    assert out.outcome == "succeeded", out.result
    assert len(offsets) > 30
    settled = offsets[10]  # 40 ticks after lift-off
    assert max(math.dist(settled, o) for o in offsets[10:]) < 1e-3
    final = out.result["final_position"]
    assert math.dist(final[:2], (0.45, -0.35)) < 5e-3  # the config's place position

