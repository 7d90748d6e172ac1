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


# ---------------------------------------------------------------------------------------------- composition
BOT = {
    "world": {"max_time": 3.0, "seed": 2},
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
               "wall": {"shape": "box", "size": [0.1, 1.0, 0.3], "mass": 0, "position": [3.0, 0, 0.15]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
    "sensors": {"bump": {"type": "contact", "body": "robot", "other": "wall"}},
    "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
}
LEAVES = {  # type -> (config, commands the drive, can succeed)
    "out": ({"type": "go_to_goal", "goal": [0.5, 0.0], "scan": ""}, True, True),
    "guard": ({"type": "guard", "sensor": "bump"}, False, False),
    "endless": ({"type": "record", "components": ["drive"], "duration": 0}, False, False),
    "log": ({"type": "record", "components": ["drive"], "duration": 1.0}, False, True),
}
CHILDREN = {"parallel": "children", "fallback": "children", "sequence": "steps"}

def composite(inner: st.SearchStrategy[object]) -> st.SearchStrategy[object]:
    return st.tuples(st.sampled_from(sorted(CHILDREN)), st.sampled_from(["all", "one"]),
                     st.lists(inner, min_size=2, max_size=3))


trees = composite(st.recursive(st.sampled_from(sorted(LEAVES)), composite, max_leaves=5))


def to_config(tree: object, names: list[str]) -> dict[str, object]:
    """The tree as a behaviour table, each node named n0, n1 ... in pre-order."""
    name = f"n{len(names)}"
    names.append(name)
    if isinstance(tree, str):
        return {**LEAVES[tree][0], "name": name}
    kind, success, children = tree  # type: ignore[misc]
    table: dict[str, object] = {"type": kind, "name": name, CHILDREN[kind]: [to_config(c, names) for c in children]}
    if kind == "parallel":
        table["success"] = success
    return table


def commands(tree: object) -> bool:
    return LEAVES[tree][1] if isinstance(tree, str) else any(commands(c) for c in tree[2])  # type: ignore[index]


def can_succeed(tree: object) -> bool:
    if isinstance(tree, str):
        return LEAVES[tree][2]
    kind, success, children = tree  # type: ignore[misc]
    able = [can_succeed(c) for c in children]
    return any(able) if kind == "fallback" or (kind == "parallel" and success == "one") else all(able)


def expected(tree: object, table: dict[str, object], key: str, out: set[tuple[str, str]]) -> None:
    """The problems the docstring's rules give, computed from the tree (key, the line's distinctive words)."""
    if isinstance(tree, str):
        return
    kind, success, children = tree  # type: ignore[misc]
    tables: list[dict[str, object]] = table[CHILDREN[kind]]  # type: ignore[assignment]
    keys = [f"{key}.{CHILDREN[kind]}[{i}]" for i in range(len(children))]
    if kind == "parallel":
        owner = None
        for child, sub, at in zip(children, tables, keys, strict=True):
            if commands(child):
                if owner is not None:
                    out.add((at, f"{owner!r} and {sub['name']!r} both command actuator 'drive'"))
                owner = owner or sub["name"]
        never = [sub["name"] for child, sub in zip(children, tables, strict=True) if not can_succeed(child)]
        if never and (success == "all" or len(never) == len(children)):
            out.add((f"{key}.success", f"success = {success!r} can never be met: "
                                       f"{', '.join(repr(n) for n in never)} never succeed"))
    for child, sub, at in zip(children, tables, keys, strict=True):
        expected(child, sub, at, out)


@pytest.mark.slow  # a world built per example (~0.1 s)
@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(tree=trees, monitor=st.sampled_from([None, "out", "guard"]))
def test_a_composition_is_refused_exactly_where_its_rules_say(tree: object, monitor: str | None) -> None:
    raw = {**BOT, "behaviour": to_config(tree, [])}
    del raw["behaviour"]["name"]  # type: ignore[attr-defined] # the task itself has no name
    if monitor is not None:
        raw["monitors"] = {"m": {**LEAVES[monitor][0]}}
    want: set[tuple[str, str]] = set()
    expected(tree, raw["behaviour"], "behaviour", want)  # type: ignore[arg-type]
    if monitor == "out":
        want.add(("monitors.m", "a monitor observes, and type 'go_to_goal' commands drive"))
    sim = build(raw)
    try:
        problems = [p for p in sim.preflight() if p.key.startswith(("behaviour", "monitors"))]
    finally:
        sim.close()
    assert len(problems) == len(want), [(p.key, p.message) for p in problems]
    for key, words in want:
        assert any(p.key == key and words in p.message and "\n" not in p.message for p in problems), (key, words)
