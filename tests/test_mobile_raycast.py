"""RayCaster: the numpy path gives PyBullet's own answers (body, link, fraction, point, normal) on random scenes.

The reference is the same caster with ``analytic=False`` (every ray through ``rayTestBatch``), on the same world.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from robokit_plugins.raycast import RayCaster

from robokit.core.world import World

RANGE = 5.0


def random_scene(seed: int) -> tuple[World, np.random.Generator]:
    """Mesh boxes (rotated about z, a few tilted, some touching), convex boxes, cylinders, a sphere, a URDF robot
    and a URDF plane, scattered over an 8 m square."""
    rng = np.random.default_rng(seed)
    w = World(seed=seed)
    c = w.client
    w.load_urdf("plane", "plane.urdf")
    for i in range(9):
        size = [rng.uniform(0.05, 3.0), rng.uniform(0.05, 1.0), rng.uniform(0.2, 1.0)]
        rpy = [0.0, 0.0, rng.uniform(-math.pi, math.pi)] if i < 7 else list(rng.uniform(-0.6, 0.6, 3))
        pos = [*rng.uniform(-4, 4, 2), size[2] / 2]
        w.add_primitive(f"mesh_{i}", "box", size=size, mass=0, mesh_collision=True, position=pos,
                        orientation=c.getQuaternionFromEuler(rpy))
    # two mesh boxes sharing a face, and a wall corner where two mesh boxes overlap: ties for Bullet to break
    w.add_primitive("pair_a", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[5.0, 0.0, 0.25])
    w.add_primitive("pair_b", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[6.0, 0.0, 0.25])
    w.add_primitive("corner_a", "box", size=[3, 0.1, 0.4], mass=0, mesh_collision=True, position=[0.0, 5.0, 0.2])
    w.add_primitive("corner_b", "box", size=[0.1, 3, 0.4], mass=0, mesh_collision=True, position=[1.45, 3.55, 0.2])
    for i in range(3):
        xy = list(rng.uniform(-4, 4, 2))
        w.add_primitive(f"box_{i}", "box", size=[0.3, 0.4, 0.5], mass=0, position=[*xy, 0.25],
                        orientation=c.getQuaternionFromEuler([0, 0, rng.uniform(-3, 3)]))
        w.add_primitive(f"can_{i}", "cylinder", radius=0.1, height=0.3, mass=0.2,
                        position=[*rng.uniform(-4, 4, 2), 0.15])
    w.add_primitive("ball", "sphere", radius=0.2, mass=1.0, position=[*rng.uniform(-4, 4, 2), 0.2])
    w.load_urdf("robot", "robots/diffbot.urdf", position=[*rng.uniform(-4, 4, 2), 0.06])
    return w, rng


def random_rays(rng: np.random.Generator, n: int = 360) -> tuple[np.ndarray, np.ndarray]:
    """A lidar-like fan (random origin, heading, small tilts, random start offsets) plus rays in random
    directions, some vertical and some exactly horizontal."""
    origin = np.array([*rng.uniform(-5, 6, 2), rng.uniform(0.02, 0.8)])
    a = rng.uniform(-math.pi, math.pi) + np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    el = rng.normal(0.0, 0.05, n)
    el[: n // 8] = 0.0  # exactly horizontal: zero z components
    el[n // 8: n // 8 + 8] = rng.choice([-math.pi / 2, math.pi / 2], 8)  # straight down or up
    dirs = np.stack([np.cos(a) * np.cos(el), np.sin(a) * np.cos(el), np.sin(el)], axis=1)
    starts = origin + dirs * rng.uniform(0.0, 0.5, (n, 1))
    return starts, origin + dirs * RANGE


def assert_same(a, b) -> None:
    assert np.array_equal(a.body, b.body)
    assert np.array_equal(a.link, b.link)
    assert np.allclose(a.fraction, b.fraction, rtol=0, atol=1e-9)
    assert np.allclose(a.position, b.position, rtol=0, atol=1e-9)
    assert np.allclose(a.normal, b.normal, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_numpy_path_gives_pybullets_answers_on_random_scenes(seed: int) -> None:
    w, rng = random_scene(seed)
    with w:
        fast, reference = RayCaster(w), RayCaster(w, analytic=False)
        for _ in range(12):
            starts, ends = random_rays(rng)
            assert_same(fast.cast(starts, ends), reference.cast(starts, ends))
        # the numpy path answered most rays itself, and the reference cast every ray
        assert fast.rays_cast < 0.5 * fast.rays_total
        assert reference.rays_cast == reference.rays_total


def test_rays_from_inside_a_box_along_its_faces_and_ties_go_to_pybullet() -> None:
    with World() as w:
        w.add_primitive("a", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[0, 0, 0.25])
        w.add_primitive("b", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[1, 0, 0.25])
        fast, reference = RayCaster(w), RayCaster(w, analytic=False)
        starts = np.array([[0.0, 0.0, 0.25],    # inside box a
                           [-2.0, 0.5, 0.25],   # along a's side face (y = 0.5)
                           [-2.0, 0.0, 0.5],    # along both boxes' top faces
                           [0.5, -2.0, 0.25],   # straight at the shared face
                           [-2.0, 0.2, 0.25]])  # a clean hit on a's -x face
        ends = starts + np.array([[3.0, 0, 0], [4, 0, 0], [4, 0, 0], [0, 4, 0], [4, 0, 0]])
        hits = fast.cast(starts, ends)
        assert_same(hits, reference.cast(starts, ends))
        assert hits.cast.tolist() == [True, True, True, True, False]
        assert hits.body[4] == w.body("a") and hits.fraction[4] == pytest.approx(1.5 / 4)
        assert np.allclose(hits.normal[4], [-1, 0, 0])


def test_a_moved_box_is_followed_and_a_removed_one_forgotten() -> None:
    with World() as w:
        c = w.client
        box = w.add_primitive("a", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[2, 0, 0.25])
        fast = RayCaster(w)
        starts, ends = np.array([[0.0, 0.1, 0.25]]), np.array([[5.0, 0.1, 0.25]])
        assert fast.cast(starts, ends).fraction[0] == pytest.approx(1.5 / 5)
        # turned 45 degrees: the ray meets a face 0.1 m beside the near vertical edge
        c.resetBasePositionAndOrientation(box, [3, 0, 0.25], c.getQuaternionFromEuler([0, 0, math.pi / 4]))
        hits = fast.cast(starts, ends)
        assert not hits.cast[0] and hits.fraction[0] == pytest.approx((3 - math.sqrt(0.5) + 0.1) / 5)
        w.remove_body("a")
        hits = fast.cast(starts, ends)
        assert hits.body[0] == -1 and hits.fraction[0] == 1.0


def test_a_box_the_mask_leaves_out_is_left_to_pybullet() -> None:
    with World() as w:
        box = w.add_primitive("a", "box", size=[1, 1, 0.5], mass=0, mesh_collision=True, position=[2, 0, 0.25])
        w.client.setCollisionFilterGroupMask(box, -1, 0x100, -1)
        fast = RayCaster(w, mask=-1 ^ 0x100)
        hits = fast.cast(np.array([[0.0, 0.0, 0.25]]), np.array([[5.0, 0.0, 0.25]]))
        assert hits.body[0] == -1 and hits.cast[0]  # probed at set-up: PyBullet's rays do not see it


def fan(origin: list[float], n: int = 360, tilt: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A lidar-like fan of ``n`` rays from ``origin`` (tilted about x by ``tilt`` rad), 0.1 m to RANGE."""
    a = np.linspace(-math.pi, math.pi, n, endpoint=False)
    dirs = np.stack([np.cos(a), np.sin(a) * math.cos(tilt), np.sin(a) * math.sin(tilt)], axis=1)
    return np.asarray(origin) + dirs * 0.1, np.asarray(origin) + dirs * RANGE


def test_bodies_moved_between_casts_are_followed() -> None:
    """The other bodies' bounding boxes are read at each cast, in the same pass as the mesh boxes: a can pushed in
    front of a wall between two casts is seen by the next one, a box teleported away is no longer hit."""
    with World() as w:
        c = w.client
        w.add_primitive("wall", "box", size=[0.1, 4, 0.5], mass=0, mesh_collision=True, position=[2, 0, 0.25])
        w.add_primitive("post", "box", size=[0.3, 0.3, 0.5], mass=0, mesh_collision=True, position=[-1, 1, 0.25])
        can = w.add_primitive("can", "cylinder", radius=0.05, height=0.2, mass=0.2, position=[0, -6, 0.1])
        fast, reference = RayCaster(w), RayCaster(w, analytic=False)
        starts, ends = fan([0.0, 0.0, 0.1])
        before = fast.cast(starts, ends)
        assert_same(before, reference.cast(starts, ends))
        assert w.body("can") not in before.body and not before.cast[180]  # ray 180 points along +x: the wall
        assert w.body("post") in before.body
        c.resetBasePositionAndOrientation(can, [1.0, 0.0, 0.1], [0, 0, 0, 1])
        c.resetBasePositionAndOrientation(w.body("post"), [-6, -6, 0.25], [0, 0, 0, 1])
        after = fast.cast(starts, ends)
        assert_same(after, reference.cast(starts, ends))
        assert after.body[180] == can and after.cast[180]  # crosses the can's box: PyBullet's answer
        assert w.body("post") not in after.body


def test_a_tilted_fan_and_a_changing_ray_count_give_pybullets_answers() -> None:
    """Rays not parallel to any box face (a tilted fan over a rotated box) and casts of different sizes in turn
    (the caster's per-size buffers) all give PyBullet's answers."""
    with World() as w:
        c = w.client
        w.load_urdf("plane", "plane.urdf")
        w.add_primitive("wall", "box", size=[0.1, 6, 0.5], mass=0, mesh_collision=True, position=[2, 0, 0.25],
                        orientation=c.getQuaternionFromEuler([0, 0, 0.4]))
        w.add_primitive("block", "box", size=[0.5, 0.5, 0.3], mass=0, mesh_collision=True, position=[-1, -1, 0.15])
        fast, reference = RayCaster(w), RayCaster(w, analytic=False)
        for n, tilt in ((360, 0.05), (7, -0.1), (360, 0.0), (1, 0.0)):
            starts, ends = fan([0.0, 0.0, 0.2], n, tilt)
            hits = fast.cast(starts, ends)
            assert_same(hits, reference.cast(starts, ends))
        assert fast.rays_cast < fast.rays_total  # the numpy path answered rays itself


@pytest.mark.parametrize("seed", range(3))
def test_the_lean_cast_gives_the_full_casts_bodies_and_fractions(seed: int) -> None:
    """``cast_lean`` (starts written into the caster's buffer, axis-first arrays, lengths given) answers as ``cast``
    does, bit for bit; a hit on the ``ignore`` body counts as none (body -1, fraction 1.0)."""
    w, rng = random_scene(seed)
    with w:
        lean, full = RayCaster(w), RayCaster(w)
        robot = w.body("robot")
        for _ in range(6):
            starts, ends = random_rays(rng)
            lean.starts(len(starts))[:] = starts.T
            ends_t = np.ascontiguousarray(ends.T)
            inv_len = 1.0 / np.linalg.norm(ends - starts, axis=1)
            body, frac = lean.cast_lean(ends_t, inv_len, ignore=robot)
            hits = full.cast(starts, ends, detail=False)
            assert np.array_equal(body, np.where(hits.body == robot, -1, hits.body))
            assert np.array_equal(frac, np.where(hits.body == robot, 1.0, hits.fraction))  # none: fraction 1
        assert lean.rays_cast == full.rays_cast and lean.rays_total == full.rays_total
