"""The World: bodies, names, lookups, clock, seeded placement, independence of two Worlds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robokit.core.world import World, to_quaternion, yaw_of
from robokit.errors import LookupNameError, UserError


@pytest.fixture
def world():
    with World(seed=7) as w:
        w.load_urdf("plane", "plane.urdf")
        yield w


def test_primitives_fall_and_static_ones_stay(world: World) -> None:
    world.add_primitive("box", "box", size=(0.2, 0.2, 0.2), mass=1.0, position=(0, 0, 1))
    world.add_primitive("post", "cylinder", radius=0.05, height=0.5, mass=0.0, position=(1, 0, 1))
    world.add_primitive("ball", "sphere", radius=0.1, mass=0.3, position=(-1, 0, 1))
    for _ in range(480):
        world.step()
    assert world.pose("box")[0][2] == pytest.approx(0.1, abs=0.005)
    assert world.pose("ball")[0][2] == pytest.approx(0.1, abs=0.005)
    assert world.pose("post")[0] == pytest.approx((1, 0, 1))
    assert world.tick == 480 and world.time == pytest.approx(2.0)


def test_physical_parameters_are_applied(world: World) -> None:
    world.add_primitive("b", "sphere", radius=0.05, position=(0, 0, 1), restitution=0.7, lateral_friction=1.3,
                        rolling_friction=0.01, spinning_friction=0.02, linear_damping=0.1, angular_damping=0.2)
    info = world.client.getDynamicsInfo(world.body("b"), -1)
    assert info[1] == pytest.approx(1.3)  # lateral friction
    assert info[5] == pytest.approx(0.7)  # restitution
    assert info[6] == pytest.approx(0.01) and info[7] == pytest.approx(0.02)


def test_unknown_body_lists_valid_names(world: World) -> None:
    world.add_primitive("cube", "box", position=(0, 0, 1))
    with pytest.raises(LookupNameError, match=r"unknown body 'cub' \(did you mean 'cube'\?\); valid: cube, plane"):
        world.body("cub")


def test_joint_and_link_lookup_by_name(world: World) -> None:
    world.load_urdf("kuka", "kuka_iiwa/model.urdf", fixed_base=True)
    j = world.joint("kuka", "lbr_iiwa_joint_4")
    assert j.index == 3 and j.type == "revolute" and j.lower < 0 < j.upper
    assert world.link("kuka", "lbr_iiwa_link_7") == 6
    assert world.link("kuka", world.base_link_name("kuka")) == -1
    with pytest.raises(LookupNameError, match="lbr_iiwa_joint_1"):
        world.joint("kuka", "elbow")
    with pytest.raises(LookupNameError, match="lbr_iiwa_link_7"):
        world.link("kuka", "hand")


def test_urdf_relative_to_the_config_folder(tmp_path: Path) -> None:
    (tmp_path / "door.urdf").write_text(
        '<robot name="door"><link name="frame"><inertial><mass value="0"/>'
        '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
        '<link name="panel"><inertial><mass value="2"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>'
        '</inertial><collision><geometry><box size="0.8 0.04 2"/></geometry></collision></link>'
        '<joint name="hinge" type="revolute"><parent link="frame"/><child link="panel"/>'
        '<axis xyz="0 0 1"/><limit lower="0" upper="1.57" effort="10" velocity="1"/></joint></robot>'
    )
    with World(base_dir=tmp_path) as w:
        w.load_urdf("door", "door.urdf", fixed_base=True)
        assert w.joint("door", "hinge").upper == pytest.approx(1.57)
        assert w.link("door", "panel") == 0


def test_missing_urdf_says_where_it_looked(world: World) -> None:
    with pytest.raises(UserError, match="'nope.urdf' not found"):
        world.load_urdf("x", "nope.urdf")


def test_orientation_helpers() -> None:
    q = to_quaternion((0, 0, 90))
    assert yaw_of(q) == pytest.approx(np.pi / 2)
    assert to_quaternion(quaternion=(0, 0, 2, 0)) == pytest.approx((0, 0, 1, 0))


def test_seeded_placement_is_reproducible_and_spaced() -> None:
    def draw(seed: int) -> np.ndarray:
        with World(seed=seed) as w:
            return w.sample_positions(8, (0, 0), (1, 1), min_spacing=0.2)

    a, b, c = draw(5), draw(5), draw(6)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    dists = [np.linalg.norm(p - q) for i, p in enumerate(a) for q in a[i + 1 :]]
    assert min(dists) >= 0.2
    assert np.all((a >= 0) & (a <= 1))


def test_the_generator_is_the_seeds_stream_whenever_it_is_first_used() -> None:
    """The run's generator is made on first use: the same numbers, and the same spawned children, as one made with
    the World; one assigned instead is the one used."""
    with World(seed=11) as w:
        w.step()
        assert w.rng is w.rng
        assert w.rng.random() == np.random.default_rng(11).random()
    with World(seed=11) as w:
        child = w.rng.spawn(1)[0]
        assert child.random() == np.random.default_rng(11).spawn(1)[0].random()
        w.rng = np.random.default_rng(3)
        assert w.rng.random() == np.random.default_rng(3).random()


def test_placement_avoids_boxes() -> None:
    with World(seed=1) as w:
        pts = w.sample_positions(30, (0, 0), (2, 2), avoid=[((0.5, 0.5, 0), (1.5, 1.5, 1))], clearance=0.1)
    inside = [(0.4 <= x <= 1.6 and 0.4 <= y <= 1.6) for x, y in pts]
    assert not any(inside)


def test_two_worlds_do_not_interfere() -> None:
    with World() as a, World() as b:
        a.add_primitive("ball", "sphere", radius=0.1, position=(0, 0, 2))
        b.add_primitive("ball", "sphere", radius=0.1, position=(0, 0, 2))
        b.client.setGravity(0, 0, 0)
        for _ in range(120):
            a.step()
            b.step()
        assert a.pose("ball")[0][2] < 1.0
        assert b.pose("ball")[0][2] == pytest.approx(2.0)
        assert a.client._client != b.client._client


def test_close_twice_and_duplicate_names() -> None:
    w = World()
    w.add_primitive("a", "box", position=(0, 0, 0))
    with pytest.raises(UserError, match="already exists"):
        w.add_primitive("a", "box", position=(0, 0, 0))
    w.close()
    w.close()


def test_static_box_as_triangle_mesh_collides_and_is_hit_by_rays(world: World) -> None:
    world.add_primitive("wall", "box", size=(0.2, 2.0, 1.0), mass=0.0, position=(1.0, 0.0, 0.5), mesh_collision=True)
    world.add_primitive("ledge", "box", size=(1.0, 1.0, 0.2), mass=0.0, position=(-2.0, 0.0, 0.1),
                        mesh_collision=True)
    world.add_primitive("cube", "box", size=(0.1, 0.1, 0.1), mass=0.5, position=(-2.0, 0.0, 1.0))
    for _ in range(480):
        world.step()
    assert world.pose("cube")[0][2] == pytest.approx(0.25, abs=0.005)  # resting on the mesh ledge's top face
    hit = world.client.rayTestBatch([[0.0, 0.0, 0.5]], [[3.0, 0.0, 0.5]])[0]
    assert hit[0] == world.body("wall") and hit[3][0] == pytest.approx(0.9, abs=1e-4)  # the wall's near face
    with pytest.raises(UserError, match="mass = 0"):
        world.add_primitive("bad", "box", mass=1.0, position=(0, 3, 1), mesh_collision=True)
