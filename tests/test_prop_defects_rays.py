"""A ray that starts inside a shape, and a ray of zero length, on both engines against plain geometry.

The World's rule (``robokit.engines.interface.RayCaster``, docs/engines.md "Rays: one rule on both engines"): a shape
a ray starts inside is passed through (the face it leaves by is no hit); what lies beyond it, or inside it (another
body's surface), is the answer; a zero-length segment hits nothing (body -1, fraction 1.0).

Each example builds one static container (a sphere, box, cylinder or capsule, turned by a generated rotation), a
start strictly inside it (at least 5 mm from its surface), a generated direction, a thin wall well beyond the
container across the ray's line, and sometimes a small cube inside the container ahead of the start. The expected
answer is the cube's entry, else the wall's, each by a slab test in the shape's own frame written here; the
container is never the answer.
"""

from __future__ import annotations

import hashlib
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from engine_inputs import axes, turns
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import quaternion_of, rotation

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]

KINDS = ["sphere", "box", "cylinder", "capsule"]
WALL = np.array([0.02, 0.2, 0.2])  # the wall's half extents: thin along its own x
CUBE = 0.02  # the inner cube's half edge
CONVEX_TOLERANCE = 1.2e-2
"""m: PyBullet's ray test against a convex box converges to within about a centimetre (tests/test_prop_engines_rays.py);
a static mesh box and every MuJoCo answer are exact to rounding."""


def slab_entry(centre: np.ndarray, rot: np.ndarray, half: np.ndarray, start: np.ndarray, vec: np.ndarray) -> float:
    """The fraction at which ``start + t * vec`` enters the box (``rot``: world from box), or inf if it misses."""
    o, d = rot.T @ (start - centre), rot.T @ vec
    lo, hi = -math.inf, math.inf
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if abs(o[i]) >= half[i]:
                return math.inf
            continue
        t1, t2 = (-half[i] - o[i]) / d[i], (half[i] - o[i]) / d[i]
        lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
    return lo if 0.0 <= lo < hi else math.inf


def depth(kind: str, size: tuple[float, float, float], local: np.ndarray) -> float:
    """How far (m) a point in the container's own frame lies inside its surface (negative: outside)."""
    a, b, c = size
    if kind == "sphere":
        return a - float(np.linalg.norm(local))
    if kind == "box":
        return float(np.min(np.array(size) - np.abs(local)))
    if kind == "cylinder":  # radius a, half height b
        return min(a - float(np.hypot(local[0], local[1])), b - abs(float(local[2])))
    # capsule: radius a, half length b between its caps' centres, along z
    axis_point = np.array([0.0, 0.0, min(max(float(local[2]), -b), b)])
    return a - float(np.linalg.norm(local - axis_point))


def capsule_urdf(tmp: Path, radius: float, length: float) -> str:
    text = f"""<?xml version="1.0"?>
<robot name="capsule"><link name="base">
  <inertial><origin xyz="0 0 0"/><mass value="0"/><inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial>
  <collision><origin xyz="0 0 0"/><geometry><capsule radius="{radius}" length="{length}"/></geometry></collision>
</link></robot>
"""
    path = tmp / f"capsule_{hashlib.sha256(text.encode()).hexdigest()[:16]}.urdf"
    path.write_text(text)
    return str(path)


def build_container(world: World, tmp: Path, kind: str, size: tuple[float, float, float], q: tuple) -> None:
    a, b, c = size
    if kind == "sphere":
        world.add_primitive("container", "sphere", radius=a, mass=0, orientation=q)
    elif kind == "box":
        world.add_primitive("container", "box", size=(2 * a, 2 * b, 2 * c), mass=0, orientation=q)
    elif kind == "cylinder":
        world.add_primitive("container", "cylinder", radius=a, height=2 * b, mass=0, orientation=q)
    else:
        world.load_urdf("container", capsule_urdf(tmp, a, 2 * b), fixed_base=True, orientation=q)


def start_inside(kind: str, size: tuple[float, float, float], u: tuple, v: tuple) -> np.ndarray:
    """A point of the container's own frame at least a tenth of its smallest dimension inside it."""
    a, b, c = size

    def disc(w: np.ndarray) -> np.ndarray:  # into the unit ball
        n = float(np.linalg.norm(w))
        return w / n if n > 1.0 else w

    u_, v_ = np.array(u), np.array(v)
    if kind == "sphere":
        return disc(u_) * 0.9 * a
    if kind == "box":
        return u_ * 0.9 * np.array(size)
    if kind == "cylinder":
        xy = disc(np.array([u_[0], u_[1], 0.0])) * 0.9 * a
        return xy + np.array([0.0, 0.0, u_[2] * 0.9 * b])
    return np.array([0.0, 0.0, u_[2] * b]) + disc(v_) * 0.9 * a


sizes = st.tuples(*(st.floats(0.05, 0.25),) * 3)
units = st.tuples(*(st.floats(-1.0, 1.0),) * 3)


@settings(max_examples=12, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(kind=st.sampled_from(KINDS), size=sizes, axis=axes, turn=turns, u=units, v=units,
       heading=axes, wall_axis=axes, wall_turn=turns, mesh_wall=st.booleans(), cube_at=st.floats(0.0, 1.0),
       cube=st.booleans())
def test_a_ray_starting_inside_a_shape_reports_what_lies_beyond_or_inside_it(
        world: World, tmp_path: Path, kind: str, size: tuple, axis: tuple, turn: float, u: tuple, v: tuple,
        heading: tuple, wall_axis: tuple, wall_turn: float, mesh_wall: bool, cube_at: float, cube: bool) -> None:
    q = quaternion_of(axis, turn)
    rot = rotation(q)
    local = start_inside(kind, size, u, v)
    assert depth(kind, size, local) >= 0.005 - 1e-12
    start = rot @ local
    direction = np.asarray(heading) / np.linalg.norm(heading)
    reach = float(np.linalg.norm(start)) + float(np.linalg.norm(size)) + float(np.linalg.norm(WALL)) + 0.02
    wall_centre = start + direction * reach  # the wall lies wholly outside the container, across the ray's line
    end = start + direction * (reach + 0.6)
    vec = end - start
    wall_q = quaternion_of(wall_axis, wall_turn)
    want_name, want = "wall", slab_entry(wall_centre, rotation(wall_q), WALL, start, vec)
    cube_q = quaternion_of(wall_axis, -wall_turn)
    # the cube, ahead of the start, if it fits wholly inside the container (its corners' ball within the surface)
    corner = CUBE * math.sqrt(3.0)
    cube_centre = start + direction * (corner + 0.003 + cube_at * 0.3)
    inner = cube and depth(kind, size, rot.T @ cube_centre) > corner + 0.003
    if inner:
        want_name, want = "cube", slab_entry(cube_centre, rotation(cube_q), np.full(3, CUBE), start, vec)
    assert 0.0 < want < 1.0
    build_container(world, tmp_path, kind, size, q)
    world.add_primitive("wall", "box", size=tuple(2 * WALL), mass=0, position=tuple(wall_centre),
                        orientation=wall_q, mesh_collision=mesh_wall)
    if inner:
        world.add_primitive("cube", "box", size=(2 * CUBE,) * 3, mass=0, position=tuple(cube_centre),
                            orientation=cube_q, mesh_collision=True)
    try:
        exact = world.engine == "mujoco" or mesh_wall or inner
        tol = 1e-7 if exact else CONVEX_TOLERANCE
        length = float(np.linalg.norm(vec))
        caster = world.ray_caster()
        where = f"{kind} {size} start {start.tolist()} -> {end.tolist()}"
        for detail in (True, False):
            hits = caster.cast(start[None], end[None], detail=detail)
            assert (hits.body[0], hits.link[0]) == (world.body(want_name), -1), where
            assert hits.fraction[0] * length == pytest.approx(want * length, abs=tol), where
            if detail:
                assert hits.position[0] == pytest.approx(start + hits.fraction[0] * vec, abs=1e-9), where
                assert hits.normal[0] @ vec < 0.0, where  # the face it enters, not one it leaves by
        caster.starts(1)[:] = start[:, None]
        body, frac = caster.cast_lean(end[:, None].copy(), np.array([1.0 / length]))
        assert body[0] == world.body(want_name), where
        assert frac[0] * length == pytest.approx(want * length, abs=tol), where
    finally:
        for name in ("container", "wall", "cube"):
            if name == "cube" and not inner:
                continue
            world.remove_body(name)


@settings(max_examples=10, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(points=st.lists(st.tuples(*(st.floats(-0.3, 0.3),) * 3), min_size=1, max_size=6), mesh=st.booleans())
def test_a_zero_length_ray_hits_nothing_quietly(world: World, points: list, mesh: bool) -> None:
    """Zero-length segments anywhere (inside a sphere, a box, in the open), beside ordinary ones: body -1, fraction
    1.0, no position or normal, and no warning; the ordinary ray beside them keeps its answer (the box at 0.5 m)."""
    world.add_primitive("ball", "sphere", radius=0.2, mass=0)
    world.add_primitive("slab", "box", size=(0.2, 0.6, 0.6), mass=0, position=(0.6, 0.0, 0.0), mesh_collision=mesh)
    try:
        starts = np.array([*points, (-0.5, 0.25, 0.0)], float)
        ends = starts.copy()
        ends[-1] = (1.5, 0.25, 0.0)  # an ordinary ray past the ball: the slab's face at x = 0.5, fraction 0.5
        n = len(points)
        caster = world.ray_caster()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            for detail in (True, False):
                hits = caster.cast(starts, ends, detail=detail)
                assert hits.body[:n].tolist() == [-1] * n and hits.fraction[:n].tolist() == [1.0] * n
                assert hits.link[:n].tolist() == [-1] * n
                if detail:
                    assert not hits.position[:n].any() and not hits.normal[:n].any()
                assert hits.body[n] == world.body("slab") and hits.fraction[n] == pytest.approx(0.5, abs=6e-3)
            caster.starts(n + 1)[:] = starts.T
            with np.errstate(divide="ignore"):  # the caller's 1 / 0 for a zero-length segment
                inv_len = 1.0 / np.linalg.norm(ends - starts, axis=1)
            body, frac = caster.cast_lean(np.ascontiguousarray(ends.T), inv_len)
        assert body[:n].tolist() == [-1] * n and frac[:n].tolist() == [1.0] * n
        assert body[n] == world.body("slab") and frac[n] == pytest.approx(0.5, abs=6e-3)
    finally:
        world.remove_body("ball")
        world.remove_body("slab")
