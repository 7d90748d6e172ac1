"""Ray casts on both engines against plain geometry, over generated scenes and ray batches.

The World's rule (``robokit.engines.interface.RayCaster``, docs/engines.md "Rays: one rule on both engines"): a
segment reports the first surface it *enters* between its start and its end; a shape the ray starts inside is passed
through (a surface of another shape inside it still counts); the end is not part of the segment; a zero-length
segment hits nothing. Each example builds boxes at random rotations (never the identity, never a half turn) and
spheres, overlapping or not, and casts segments from random starts (many inside a shape) and fans from one start (a
lidar's batch); every answer is judged by a slab test in each box's own frame and the sphere's quadratic, written
here. Rays whose answer would change if a shape grew or shrank by a millimetre (grazing an edge, ending on a face,
starting on one, two entries within a millimetre) are left out of the comparison: engines may differ there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import rotation

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]

NO_SHRINK = [Phase.explicit, Phase.generate]
MARGIN = {"mujoco": 1e-3, "pybullet": 1.2e-2}
"""m a shape is grown and shrunk by to tell a robust ray from a borderline one (PyBullet's ray test against a convex
primitive converges to within a few millimetres)."""


@dataclass
class Shape:
    name: str
    kind: str  # "box" or "sphere"
    centre: np.ndarray
    rot: np.ndarray  # world from shape
    half: np.ndarray  # box half extents, or (r, r, r)
    pybullet_exact: bool = False  # a static mesh box: PyBullet's answer is exact arithmetic


def interval(shape: Shape, start: np.ndarray, vec: np.ndarray, grow: float = 0.0) -> tuple[float, float,
                                                                                       np.ndarray] | None:
    """Where the line ``start + t * vec`` is inside the shape (grown by ``grow``): (t_in, t_out, outward normal at
    the entry), or None if the line misses it."""
    if shape.kind == "sphere":
        r = shape.half[0] + grow
        o = start - shape.centre
        a, b, c = vec @ vec, 2.0 * (o @ vec), o @ o - r * r
        disc = b * b - 4.0 * a * c
        if disc <= 0.0:
            return None
        root = math.sqrt(disc)
        t_in, t_out = (-b - root) / (2.0 * a), (-b + root) / (2.0 * a)
        return t_in, t_out, (o + t_in * vec) / r
    o, d = shape.rot.T @ (start - shape.centre), shape.rot.T @ vec  # the box's own frame
    h = shape.half + grow
    lo, hi, face = -math.inf, math.inf, (0, 1.0)
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if abs(o[i]) > h[i]:
                return None
            continue
        t1, t2 = (-h[i] - o[i]) / d[i], (h[i] - o[i]) / d[i]
        if min(t1, t2) > lo:
            lo, face = min(t1, t2), (i, -math.copysign(1.0, d[i]))
        hi = min(hi, max(t1, t2))
    if lo >= hi:
        return None
    return lo, hi, shape.rot[:, face[0]] * face[1]


def inside(shape: Shape, point: np.ndarray, grow: float) -> bool:
    """True if ``point`` lies inside the shape grown by ``grow`` (m)."""
    if shape.kind == "sphere":
        return bool(np.linalg.norm(point - shape.centre) < shape.half[0] + grow)
    return bool((np.abs(shape.rot.T @ (point - shape.centre)) < shape.half + grow).all())


def first_entry(shapes: list[Shape], start: np.ndarray, end: np.ndarray, grow: float = 0.0
                ) -> list[tuple[float, Shape, np.ndarray]]:
    """Every surface the segment enters in [0, 1), nearest first (a shape it starts inside is passed through)."""
    vec = end - start
    if vec @ vec < 1e-24:
        return []
    found = []
    for shape in shapes:
        got = interval(shape, start, vec, grow)
        if got is not None and 0.0 <= got[0] < 1.0:
            found.append((got[0], shape, got[2]))
    return sorted(found, key=lambda f: f[0])


def expected(shapes: list[Shape], start: np.ndarray, end: np.ndarray, engine: str
             ) -> tuple[Shape | None, float, np.ndarray] | None:
    """The rule's answer (shape, fraction, normal; shape None: no hit), or None when the ray is borderline."""
    length = float(np.linalg.norm(end - start))
    exact = first_entry(shapes, start, end)
    if length < 1e-12:
        return None, 1.0, np.zeros(3)
    margin = MARGIN[engine] / length
    grown, shrunk = first_entry(shapes, start, end, MARGIN[engine]), first_entry(shapes, start, end, -MARGIN[engine])
    names = [[f[1].name for f in entries[:1]] for entries in (exact, grown, shrunk)]
    if names[0] != names[1] or names[0] != names[2]:
        return None
    if len(exact) > 1 and exact[1][0] - exact[0][0] < 4 * margin:
        return None
    for shape in shapes:  # starts or ends within the margin of a surface
        for point in (start, end):
            if inside(shape, point, MARGIN[engine]) != inside(shape, point, -MARGIN[engine]):
                return None
        got = interval(shape, start, end - start)
        if got is not None and min(abs(got[0]), abs(got[1]), abs(got[0] - 1.0), abs(got[1] - 1.0)) < margin:
            return None
    if not exact:
        return None, 1.0, np.zeros(3)
    t, shape, normal = exact[0]
    return shape, t, normal


def quaternion(axis: tuple[float, float, float], angle: float) -> tuple[float, float, float, float]:
    k = np.asarray(axis) / np.linalg.norm(axis)
    s = math.sin(angle / 2.0)
    return (k[0] * s, k[1] * s, k[2] * s, math.cos(angle / 2.0))


axes = st.tuples(*(st.floats(-1.0, 1.0),) * 3).filter(lambda a: np.linalg.norm(a) > 0.2)
turns = st.floats(0.3, 2.8)  # rad: never the identity, never a half turn (its own inverse)
coords = st.tuples(*(st.floats(-0.6, 0.6),) * 3)
boxes = st.tuples(st.just("box"), coords, st.tuples(*(st.floats(0.05, 0.3),) * 3), axes, turns, st.integers(0, 2))
spheres = st.tuples(st.just("sphere"), coords, st.floats(0.05, 0.3), axes, turns, st.integers(0, 2))
scenes = st.lists(st.one_of(boxes, spheres), min_size=1, max_size=4)


def build(world: World, drawn: list) -> list[Shape]:
    """The drawn shapes in the world (kind 0: static, 1: static mesh box, 2: with mass) and as :class:`Shape`."""
    shapes = []
    for i, (kind, centre, size, axis, angle, flavour) in enumerate(drawn):
        name = f"s{i}"
        q = quaternion(axis, angle)
        mass = 1.0 if flavour == 2 else 0.0
        if kind == "box":
            half = np.asarray(size, float)
            world.add_primitive(name, "box", size=tuple(2 * half), mass=mass, position=centre, orientation=q,
                                mesh_collision=flavour == 1)
        else:
            half = np.full(3, float(size))
            world.add_primitive(name, "sphere", radius=float(size), mass=mass, position=centre, orientation=q)
        shapes.append(Shape(name, kind, np.asarray(centre, float), rotation(q), half, kind == "box" and flavour == 1))
    return shapes


def segments(rng: np.random.Generator, shapes: list[Shape], n: int, fan: bool) -> tuple[np.ndarray, np.ndarray]:
    """``n`` segments: from random starts (a third inside a shape) towards a shape, of random reach; some of zero
    length; ``fan``: all from one start, in random directions."""
    centres = np.array([s.centre for s in shapes])
    if fan:
        origin = rng.uniform(-1.2, 1.2, 3) if rng.random() < 0.5 else centres[rng.integers(len(shapes))]
        starts = np.repeat(origin[None], n, axis=0)
        dirs = rng.normal(size=(n, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        return starts, starts + dirs * rng.uniform(0.2, 2.5, (n, 1))
    starts = rng.uniform(-1.2, 1.2, (n, 3))
    inside = rng.random(n) < 0.33
    starts[inside] = centres[rng.integers(len(shapes), size=inside.sum())] + rng.normal(0.0, 0.03, (inside.sum(), 3))
    aims = centres[rng.integers(len(shapes), size=n)] + rng.normal(0.0, 0.15, (n, 3))
    ends = starts + (aims - starts) * rng.uniform(0.3, 2.5, (n, 1))
    ends[: n // 10] = starts[: n // 10]  # zero length
    return starts, ends


def tolerance(world: World, shape: Shape | None) -> float:
    """m: MuJoCo's ray arithmetic and a PyBullet mesh box are exact to rounding; PyBullet's ray test against a
    convex primitive converges to within about a centimetre (robokit/engines/pybullet/rays.py)."""
    if world.engine == "mujoco" or shape is None or shape.pybullet_exact:
        return 1e-7
    return 1.2e-2


def clear(world: World, shapes: list[Shape]) -> None:
    for s in shapes:
        world.remove_body(s.name)


def check(world: World, shapes: list[Shape], starts: np.ndarray, ends: np.ndarray, hits, *, hidden: str = "",
          detail: bool = True) -> int:
    """Every robust ray's body, fraction, link, position and normal against the rule; returns how many were judged."""
    judged = 0
    seen = [s for s in shapes if s.name != hidden]
    for i in range(len(starts)):
        want = expected(seen, starts[i], ends[i], world.engine)
        if want is None:
            continue
        judged += 1
        shape, t, normal = want
        length = float(np.linalg.norm(ends[i] - starts[i]))
        where = f"ray {i} {starts[i].tolist()} -> {ends[i].tolist()}"
        if shape is None:
            assert (hits.body[i], hits.fraction[i], hits.link[i]) == (-1, 1.0, -1), where
            if detail:
                assert hits.position[i].tolist() == [0.0] * 3 and hits.normal[i].tolist() == [0.0] * 3, where
            continue
        tol = tolerance(world, shape)
        assert (hits.body[i], hits.link[i]) == (world.body(shape.name), -1), where
        assert hits.fraction[i] * length == pytest.approx(t * length, abs=tol), where
        if detail:
            assert hits.position[i] == pytest.approx(starts[i] + hits.fraction[i] * (ends[i] - starts[i]),
                                                     abs=1e-9), where
            if tol < 1e-6:
                assert hits.normal[i] == pytest.approx(normal, abs=1e-6), where
            else:  # PyBullet's convex ray test: a unit normal against the ray, not always the face's (GJK's)
                assert np.linalg.norm(hits.normal[i]) == pytest.approx(1.0, abs=1e-6), where
                assert hits.normal[i] @ (ends[i] - starts[i]) < 0.0, where
        else:
            assert hits.position is None and hits.normal is None
    return judged


@pytest.mark.slow
@settings(max_examples=25, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(drawn=scenes, seed=st.integers(0, 2**31), fan=st.booleans(), detail=st.booleans())
def test_every_ray_reports_the_first_surface_it_enters(world: World, drawn: list, seed: int, fan: bool,
                                                       detail: bool) -> None:
    shapes = build(world, drawn)
    try:
        rng = np.random.default_rng(seed)
        starts, ends = segments(rng, shapes, 48, fan)
        caster = world.ray_caster()
        caster.cast(starts[:5], ends[:5])
        hits = caster.cast(starts, ends, detail=detail)
        judged = check(world, shapes, starts, ends, hits, detail=detail)
        assert judged >= 12 or world.engine == "pybullet"  # many rays are judged (PyBullet: see `expected`)
        assert caster.rays_total == len(starts) + 5 and hits.cast.dtype == bool and len(hits.cast) == len(starts)
        assert 0 <= caster.rays_cast <= caster.rays_total
        if world.engine == "mujoco":  # MuJoCo casts every ray itself
            assert hits.cast.all() and caster.rays_cast == caster.rays_total
    finally:
        clear(world, shapes)


@pytest.mark.slow
@settings(max_examples=15, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(drawn=scenes, seed=st.integers(0, 2**31), fan=st.booleans(), pick=st.integers(0, 3))
def test_a_hidden_body_is_seen_only_by_casters_that_see_hidden_ones(world: World, drawn: list, seed: int,
                                                                    fan: bool, pick: int) -> None:
    shapes = build(world, drawn)
    try:
        hidden = shapes[pick % len(shapes)]
        world.hide_from_rays(world.body(hidden.name))
        starts, ends = segments(np.random.default_rng(seed), shapes, 32, fan)
        check(world, shapes, starts, ends, world.ray_caster().cast(starts, ends))  # default casters see it
        blind = world.ray_caster(skip=(world.body(hidden.name),), see_hidden=False)
        check(world, shapes, starts, ends, blind.cast(starts, ends), hidden=hidden.name)
    finally:
        clear(world, shapes)


@pytest.mark.slow
@settings(max_examples=15, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(drawn=scenes, seed=st.integers(0, 2**31), fan=st.booleans(), pick=st.integers(-1, 3))
def test_lean_casts_answer_as_full_ones_and_ignore_one_body(world: World, drawn: list, seed: int, fan: bool,
                                                           pick: int) -> None:
    """``cast_lean`` (a lidar's scan): from the caster's own start buffer, the same bodies and fractions as the
    rule; a ray whose first surface belongs to the ``ignore`` body reads as no hit (body -1, fraction 1.0), and
    does not see through it."""
    shapes = build(world, drawn)
    try:
        ignored = -2 if pick < 0 else world.body(shapes[pick % len(shapes)].name)
        starts, ends = segments(np.random.default_rng(seed), shapes, 40, fan)
        keep = np.linalg.norm(ends - starts, axis=1) > 1e-9  # cast_lean is given 1 / length
        starts, ends = starts[keep], ends[keep]
        caster = world.ray_caster()
        caster.refresh()
        buffer = caster.starts(len(starts))
        assert buffer.shape == (3, len(starts))
        buffer[:] = starts.T
        inv_len = 1.0 / np.linalg.norm(ends - starts, axis=1)
        for refresh in (True, False):
            body, frac = caster.cast_lean(np.ascontiguousarray(ends.T), inv_len, ignore=ignored, refresh=refresh)
            assert body.shape == frac.shape == (len(starts),)
            for i in range(len(starts)):
                want = expected(shapes, starts[i], ends[i], world.engine)
                if want is None:
                    continue
                shape, t, _ = want
                where = f"ray {i} {starts[i].tolist()} -> {ends[i].tolist()} ignoring {ignored}"
                if shape is None or world.body(shape.name) == ignored:
                    assert (body[i], frac[i]) == (-1, 1.0), where
                    continue
                length = 1.0 / inv_len[i]
                assert body[i] == world.body(shape.name), where
                assert frac[i] * length == pytest.approx(t * length, abs=tolerance(world, shape)), where
        assert caster.rays_total == 2 * len(starts)
        assert caster.rays_cast == caster.rays_total or world.engine == "pybullet"  # MuJoCo casts each ray itself
        assert 0 <= caster.rays_cast <= caster.rays_total
    finally:
        clear(world, shapes)


@pytest.mark.parametrize("flavour", ["convex", "mesh"])
def test_a_ray_starting_inside_a_slab_reads_the_plane_beneath_it(world: World, flavour: str) -> None:
    """A range sensor on a body sunk into a slab (either collision flavour of a static box): its downward ray
    leaves the slab through its bottom face, which is no hit, and reads the plane 0.08 m + 1 m below its start;
    ``cast_lean`` ignoring the plane reads nothing, as a ray that hits nothing (body -1, fraction 1.0)."""
    plane = world.load_urdf("plane", "plane.urdf")
    world.add_primitive("slab", "box", size=(0.4, 0.4, 0.1), mass=0, position=(0, 0, 0.05),
                        mesh_collision=flavour == "mesh")
    try:
        starts, ends = np.array([[0.0, 0.0, 0.08], [0.1, 0.1, 0.02]]), np.array([[0.0, 0.0, -1.0], [0.1, 0.1, -1.0]])
        for detail in (True, False):
            hits = world.ray_caster().cast(starts, ends, detail=detail)
            assert hits.body.tolist() == [plane, plane]
            assert hits.fraction == pytest.approx([0.08 / 1.08, 0.02 / 1.02], abs=1e-6)
        caster = world.ray_caster()
        caster.starts(2)[:] = starts.T
        body, frac = caster.cast_lean(np.ascontiguousarray(ends.T), 1.0 / np.array([1.08, 1.02]), ignore=plane)
        assert body.tolist() == [-1, -1] and frac.tolist() == [1.0, 1.0]
        # from above, the slab is the first surface: ignoring it reads nothing, not the plane beneath it
        slab = world.body("slab")
        above, below = np.array([[0.05, 0.0, 0.5], [0.3, 0.3, 0.5]]), np.array([[0.05, 0.0, -0.5], [0.3, 0.3, -0.5]])
        caster.starts(2)[:] = above.T
        for ignore, want in ((slab, ([-1, plane], [1.0, 0.5])), (-2, ([slab, plane], [0.4, 0.5]))):
            body, frac = caster.cast_lean(np.ascontiguousarray(below.T), np.array([1.0, 1.0]), ignore=ignore)
            assert body.tolist() == want[0] and frac == pytest.approx(want[1], abs=1e-6)
    finally:
        world.remove_body("slab")
        world.remove_body("plane")
