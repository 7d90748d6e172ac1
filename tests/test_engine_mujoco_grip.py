"""Grasps on MuJoCo (robokit/engines/mujoco/grip.py): a cube the Panda squeezes moves with the hand while it is
carried (within 1 mm of where it settled in the fingers), and is put down where it was asked; a cube squeezed
between two anchored fingers holds a load its friction can carry and slides under one it cannot (Coulomb's rule,
with the normal forces read from the world's contacts). Real physics; the oracles are the world's poses and
contacts."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from robokit.config import load_config
from robokit.core.simulation import Simulation
from robokit.engines.interface import World
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


@pytest.mark.slow
def test_a_squeezed_cube_moves_with_the_hand(plugins: Any) -> None:
    out, offsets, _ = carried(plugins, {"world.seed": 207})
    assert out.outcome == "succeeded", out.result
    assert len(offsets) > 30
    settled = offsets[10]  # 40 ticks after lift-off
    assert max(math.dist(settled, o) for o in offsets[10:]) < 1e-3
    final = out.result["final_position"]
    assert math.dist(final[:2], (0.45, -0.35)) < 5e-3  # the config's place position



def pushed_down(load: float) -> float:
    """A 5 cm cube squeezed between two fixed 'fingers' (``friction_anchor``, friction 1) that overlap it by 0.5 mm
    each; pushed down for 0.5 s with ``load`` times what friction can carry (friction 1 x the contacts' normal
    forces, read from the world). How far it went down (m)."""
    world = World.create("mujoco", time_step=1.0 / 240.0)
    try:
        for name, x in (("left", -0.0345), ("right", 0.0345)):
            world.add_primitive(name, "box", size=(0.02, 0.06, 0.06), mass=0, position=(x, 0.0, 0.5))
            world.set_dynamics(name, -1, lateral_friction=1.0, friction_anchor=True)
        world.add_primitive("cube", "box", size=(0.05, 0.05, 0.05), mass=0.1, position=(0.0, 0.0, 0.5))
        world.set_dynamics("cube", -1, lateral_friction=1.0)
        for _ in range(60):  # squeezed and settled (its weight is well within what friction carries)
            world.step()
        carried = sum(c.normal_force for c in world.contacts("cube"))
        assert carried > 10.0
        start = world.pose("cube")[0][2]
        for _ in range(120):
            world.apply_force("cube", (0.0, 0.0, -load * carried))
            world.step()
        return start - world.pose("cube")[0][2]
    finally:
        world.close()


def test_a_squeezed_cube_holds_a_load_its_friction_can_carry() -> None:
    assert pushed_down(0.3) < 2e-3  # soft friction alone creeps about 5 mm here


def test_a_squeezed_cube_slides_under_a_load_its_friction_cannot_carry() -> None:
    assert pushed_down(2.0) > 0.03  # an anchor that never let go would hold it within 5 mm
