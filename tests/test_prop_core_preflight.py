"""The core's preflight check of spawned bodies (:mod:`robokit.core.preflight`, docs/cli.md ``validate``), as a
property over generated placements: a pair of bodies is one problem exactly when they interpenetrate by more than
5 mm and at least one of them moves (two static bodies may meet: walls at a corner). The problem is one line at the
later body's config key, naming both bodies and the depth in millimetres. The oracle is the geometry of two
axis-aligned boxes: their depth is the smallest overlap along the three axes.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import pytest
import tomllib
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from robokit.core.preflight import OVERLAP_TOLERANCE, overlapping_bodies
from robokit.core.simulation import Simulation, build

SIZES = {"wall_a": (0.4, 0.1, 0.2), "wall_b": (0.1, 0.4, 0.2), "cube_a": (0.1, 0.1, 0.1), "crate": (0.2, 0.12, 0.08)}
STATIC = {"wall_a", "wall_b"}


def scene_toml() -> str:
    parts = ["[world]\nseed = 0\n"]
    for i, (name, size) in enumerate(SIZES.items()):
        mass = 0.0 if name in STATIC else 0.3
        parts.append(f'[bodies.{name}]\nshape = "box"\nsize = {list(size)}\nmass = {mass}\n'
                     f"position = [{3 * i}, 5, 1]\n")
    return "\n".join(parts)


@pytest.fixture
def sim() -> Iterator[Simulation]:
    built = build(tomllib.loads(scene_toml()))
    try:
        yield built
    finally:
        built.close()


def depth(pa: tuple[float, ...], a: str, pb: tuple[float, ...], b: str) -> float:
    """How deep two axis-aligned boxes interpenetrate (<= 0: apart)."""
    return min((SIZES[a][k] + SIZES[b][k]) / 2 - abs(pa[k] - pb[k]) for k in range(3))


coord = st.floats(-0.3, 0.3).map(lambda x: round(x, 3))
places = st.fixed_dictionaries({n: st.tuples(coord, coord, coord) for n in SIZES})


@settings(max_examples=30, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(places=places)
def test_a_pair_is_a_problem_when_it_overlaps_beyond_the_tolerance_and_one_of_it_moves(
        sim: Simulation, places: dict[str, tuple[float, float, float]]) -> None:
    c = sim.world.client
    for name, where in places.items():
        c.resetBasePositionAndOrientation(sim.world.body(name), where, (0, 0, 0, 1))
    depths = {}
    for a, b in itertools.combinations(sim.world.body_names, 2):
        d = depth(places[a], a, places[b], b)
        assume(abs(d - OVERLAP_TOLERANCE) > 0.001)  # no pair on the edge of the tolerance
        depths[(a, b)] = d
    want = [(a, b) for (a, b), d in depths.items() if d > OVERLAP_TOLERANCE and not (a in STATIC and b in STATIC)]
    problems = overlapping_bodies(sim.world, sim.body_keys)
    assert len(problems) == len(want)
    for (a, b), problem in zip(want, problems, strict=True):
        assert problem.key == f"bodies.{b}" and "\n" not in problem.message
        head = f"{b!r} is spawned overlapping {a!r} (bodies.{a}) by "
        assert problem.message.startswith(head) and problem.message.endswith(" mm; move one of them")
        mm = int(problem.message[len(head):].split()[0])
        assert abs(mm - depths[(a, b)] * 1000) <= 1.5, (a, b, mm, depths[(a, b)])
