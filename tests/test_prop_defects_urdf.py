"""A URDF rewritten on disk and loaded again builds its new content, on both engines.

PyBullet keeps a URDF it parsed under its path for the client's life (docs/engines.md "URDFs rewritten on disk"):
each example writes a generated sequence of contents (a box link's size, colour and mass) to one path of the test's
folder, loading the file after each write into one world, and checks every body against the content written just
before it was loaded: its bounding box against the box's size written here, its colour and mass against the file's.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]


def urdf(size: tuple[float, float, float], rgba: tuple[float, float, float], mass: float) -> str:
    box = " ".join(f"{v!r}" for v in size)
    colour = " ".join(f"{v!r}" for v in rgba)
    return f"""<?xml version="1.0"?>
<robot name="block"><link name="base">
  <inertial><origin xyz="0 0 0"/><mass value="{mass!r}"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  <visual><geometry><box size="{box}"/></geometry><material name="paint"><color rgba="{colour} 1"/></material></visual>
  <collision><geometry><box size="{box}"/></geometry></collision>
</link></robot>
"""


contents = st.tuples(st.tuples(*(st.sampled_from([0.05, 0.1, 0.2, 0.35, 0.5]),) * 3),
                     st.tuples(*(st.sampled_from([0.0, 0.25, 0.5, 1.0]),) * 3),
                     st.sampled_from([0.5, 1.0, 2.0]))


@settings(max_examples=5, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(writes=st.lists(contents, min_size=2, max_size=5))
def test_a_rewritten_urdf_loads_its_new_content(world: World, tmp_path: Path, writes: list) -> None:
    path = tmp_path / "block.urdf"  # one path for every write of every example
    names = []
    try:
        for k, (size, rgba, mass) in enumerate(writes):
            path.write_text(urdf(size, rgba, mass))
            names.append(f"block{k}")
            x = 2.0 * k
            world.load_urdf(names[-1], str(path), position=(x, 0.0, 1.0))  # never stepped
            lo, hi = world.body_aabb(names[-1])
            half = [s / 2.0 for s in size]
            assert lo == pytest.approx((x - half[0], -half[1], 1.0 - half[2]), abs=1e-6), f"write {k}: {size}"
            assert hi == pytest.approx((x + half[0], half[1], 1.0 + half[2]), abs=1e-6), f"write {k}: {size}"
            assert world.visual_rgba(names[-1]) == pytest.approx((*rgba, 1.0)), f"write {k}: {rgba}"
            assert world.mass(names[-1]) == pytest.approx(mass), f"write {k}: {mass}"
    finally:
        for name in names:
            world.remove_body(name)


def sdf(size: tuple[float, float, float], mass: float) -> str:
    box = " ".join(f"{v!r}" for v in size)
    return f"""<?xml version="1.0"?>
<sdf version="1.6"><world name="w"><model name="block"><link name="base">
  <inertial><mass>{mass!r}</mass><inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz>
    <ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>
  <collision name="box"><geometry><box><size>{box}</size></box></geometry></collision>
</link></model></world></sdf>
"""


@settings(max_examples=3, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(writes=st.lists(contents, min_size=2, max_size=4))
def test_a_rewritten_sdf_loads_its_new_content_on_pybullet(tmp_path: Path, writes: list) -> None:
    """SDF is PyBullet's only (the mujoco engine loads URDF and MJCF): its parses are kept by path as a URDF's are."""
    path = tmp_path / "block.sdf"
    with World.engine_class("pybullet")(seed=0) as world:
        for k, (size, _, mass) in enumerate(writes):
            path.write_text(sdf(size, mass))
            x = 2.0 * k
            world.load_model(f"block{k}", str(path), "sdf", position=(x, 0.0, 1.0))
            lo, hi = world.body_aabb(f"block{k}")
            half = [s / 2.0 for s in size]
            assert lo == pytest.approx((x - half[0], -half[1], 1.0 - half[2]), abs=1e-6), f"write {k}: {size}"
            assert hi == pytest.approx((x + half[0], half[1], 1.0 + half[2]), abs=1e-6), f"write {k}: {size}"
            assert world.mass(f"block{k}") == pytest.approx(mass), f"write {k}: {mass}"
