"""What ``robokit validate`` refuses before a sort or a patrol runs, judged by plain geometry written here.

docs/vision.md: validate refuses a bin whose place slots or an object the arm cannot reach, an object outside the
camera's view, and a colour no class matches, one line each with the key. Here the sort is set up on the scripted
table of tests/test_prop_behaviours_sort_records.py with an arm that reaches a generated radius from its base and a
camera that sees a generated rectangle of the table; every problem it reports is compared with the list the test
works out from those two shapes. docs/mobile.md: validate refuses a waypoint outside the world (the walled arena when
the map encloses the robot, else the floor); the test draws waypoints inside and outside the walls.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.checks.scripted import StandIn
from robokit.components import SetupContext
from robokit.msgs.arm import ArmState, GripperState
from robokit.testing import make_sim

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_pins_patrol import room  # noqa: E402  (the walled room of patrol's pins)
from test_prop_behaviours_sort_records import BINS, SIZE, Camera, Readings, Table, Tiny  # noqa: E402

SLOT = 0.07 / 2
FLOOR = 0.008  # BinConfig's floor above the bin's base


class Arm(StandIn):
    """An ik_arm as validate asks it: ``check_reach`` says "" within ``radius`` of its base, else why not."""

    def __init__(self, radius: float) -> None:
        super().__init__("arm", ArmState, "actuator")
        self.radius, self.asked = radius, []  # type: ignore[var-annotated]

    def check_reach(self, position: Any, yaw: float = 0.0, orientation: Any = None) -> str:
        self.asked.append(tuple(position))
        d = math.dist(position, (0.0, 0.0, 0.0))
        return "" if d <= self.radius else f"unreachable: {d:.3f} m from the base"


class View(StandIn):
    """A camera that sees the table inside a rectangle (x, y)."""

    def __init__(self, low: tuple[float, float], high: tuple[float, float]) -> None:
        super().__init__("cam", object, "sensor")
        self.low, self.high = low, high

    def in_view(self, point: Any) -> bool:
        return all(lo <= p <= hi for p, lo, hi in zip(point[:2], self.low, self.high, strict=True))


@settings(max_examples=12, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.sampled_from(["red", "blue", "green", "grey"]), st.floats(0.3, 0.85),
                          st.floats(-0.3, 0.3)), min_size=1, max_size=5),
       st.floats(0.55, 0.9), st.floats(0.3, 0.5), st.floats(0.15, 0.3))
def test_sort_validate_refuses_exactly_what_the_arm_and_camera_cannot_do(cubes: list[tuple[str, float, float]],
                                                                        radius: float, view_x: float,
                                                                        view_y: float) -> None:
    from robokit_behaviours.sort import Sort, SortConfig

    colours = {f"{c}_{i}": c for i, (c, _, _) in enumerate(cubes)}
    spots = {f"{c}_{i}": (x, y, SIZE / 2) for i, (c, x, y) in enumerate(cubes)}
    cell = Tiny({n: list(p) for n, p in spots.items()}, {n: ["ok"] for n in spots})
    camera = Camera(cell, colours, 1.0)
    camera.config = SimpleNamespace(camera="cam")  # type: ignore[attr-defined]
    arm, view = Arm(radius), View((view_x, -view_y), (view_x + 0.35, view_y))
    components = {"detector": camera, "cam": view, "arm": arm,
                  "gripper": StandIn("gripper", GripperState, "actuator")}
    keys = {n: f"bodies.{n.split('_')[0]}" for n in spots}
    ctx = SetupContext(Table(cell, colours), np.random.default_rng(0), "behaviour", Readings(camera),  # type: ignore[arg-type]
                       components, Path("."), lambda kind, **data: None, keys)
    sort = Sort("sort", SortConfig.model_validate({"bins": {c: {"body": f"{c}_bin"} for c in BINS}}))
    sort.setup(ctx)
    found = [(p.key, p.message) for p in sort.preflight(ctx)]
    # the oracle: each bin's slots (its centre and the four corners of a 7 cm square) at the release height; each
    # cube's centre for the grasp and its top face for the camera
    want = []
    for colour, (bx, by) in BINS.items():
        z = 0.0 + FLOOR + SIZE / 2 + 0.004  # a slot's object centre, plus pick_place's place_clearance
        slots = [(bx + ox, by + oy, z) for ox, oy in ((-SLOT, -SLOT), (SLOT, SLOT), (-SLOT, SLOT), (SLOT, -SLOT),
                                                      (0.0, 0.0))]
        far = next((s for s in slots if math.dist(s, (0, 0, 0)) > radius), None)
        if far is not None:
            want.append((f"behaviour.bins.{colour}", f"bin '{colour}_bin' is out of the reach of arm 'arm': "
                         f"unreachable: {math.dist(far, (0, 0, 0)):.3f} m from the base"))
    for name, (x, y, z) in spots.items():
        where = f"({x:.3f}, {y:.3f}, {z:.3f})"
        if colours[name] == "grey":
            want.append((f"{keys[name]}.rgba", f"colour [0.5, 0.5, 0.5, 1.0] of '{name}' matches no colour class of "
                         "detector 'detector' (red, blue, green): the sort could never see it; change the colour or "
                         "add a class"))
            continue
        if colours[name] == "green":
            continue
        if not view.in_view((x, y, z + SIZE / 2)):
            want.append((keys[name], f"{name} at {where} is outside the view of camera 'cam': the sort would never "
                         "see it"))
        d = math.dist((x, y, z), (0, 0, 0))
        if d > radius:
            want.append((keys[name], f"{name} at {where} is out of the reach of arm 'arm': unreachable: {d:.3f} m "
                         "from the base"))
    assert found == want


@settings(max_examples=6, deadline=None, derandomize=True)
@example([(-1.5, 0.5), (0.5, 1.5), (3.0, -2.0), (4.5, 2.9)])
@given(st.lists(st.tuples(st.floats(-1.6, 4.6), st.floats(-2.1, 3.1)), min_size=1, max_size=3))
def test_patrol_validate_refuses_exactly_the_waypoints_outside_the_walls(points: list[tuple[float, float]]) -> None:
    """The walled room: its walls' outer faces bound the map's extent, x -1.10..4.10, y -1.60..2.60 (from their
    sizes and places in tests/test_pins_patrol.py). A waypoint beyond them is refused at its key, naming the bounds;
    one inside is not (waypoints inside the box are refused earlier, at setup, and not drawn here)."""
    lo, hi = (-1.1, -1.6), (4.1, 2.6)
    solid = [((1.1, 0.1), (1.9, 0.9)), ((-1.1, -1.6), (4.1, -1.5)), ((-1.1, 2.5), (4.1, 2.6)),
             ((-1.1, -1.6), (-1.0, 2.6)), ((4.0, -1.6), (4.1, 2.6))]  # the box and the four walls

    def near_a_body(x: float, y: float) -> bool:  # inside one grown by robot_radius (0.2 m), and a margin
        return any(a[0] - 0.22 <= x <= b[0] + 0.22 and a[1] - 0.22 <= y <= b[1] + 0.22 for a, b in solid)

    points = [(round(x, 3), round(y, 3)) for x, y in points if not near_a_body(x, y)]
    if not points:
        return
    with make_sim(room({"waypoints": [list(p) for p in points]})) as sim:
        found = [(p.key, p.message) for p in sim.behaviour.preflight(sim.behaviour.ctx)]
    want = [(f"behaviour.waypoints[{i}]", f"({x:g}, {y:g}) is outside the map's extent (x -1.10..4.10, y -1.60..2.60)")
            for i, (x, y) in enumerate(points) if not (lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1])]
    assert found == want


@settings(max_examples=12, deadline=None, derandomize=True)
@given(st.booleans(), st.integers(0, 2), st.integers(0, 2), st.floats(0.5, 0.8),
       st.lists(st.tuples(st.floats(0.3, 0.8), st.floats(-0.4, 0.4)), min_size=6, max_size=6))
def test_pick_place_validate_refuses_each_job_and_the_place_out_of_reach(one: bool, named: int, given_at: int,
                                                                        radius: float,
                                                                        spots: list[tuple[float, float]]) -> None:
    """docs/arm.md: validate refuses a place position or an object the arm cannot reach, at its key: the place
    position, the body's section, or ``pick_positions[i]`` for a job given by where it lies."""
    from robokit.testing import ScriptedRun

    if not (one or named or given_at):
        return
    names = ["solo"] * one + [f"cube{i}" for i in range(named)]
    where = {n: (x, y, SIZE / 2) for n, (x, y) in zip(names, spots, strict=False)}
    positions = [(x, y, SIZE / 2) for x, y in spots[len(names):len(names) + given_at]]
    place = (spots[-1][0], spots[-1][1], SIZE / 2)
    config: dict[str, Any] = {"pose_sensor": "poses", "place_position": list(place), "object_size": SIZE,
                              "objects": names[one:], "pick_positions": [list(p) for p in positions]}
    if one:
        config["object"] = "solo"
    run = ScriptedRun("pick_place", config, components={"arm": (ArmState, "actuator"),
                                                         "gripper": (GripperState, "actuator"), "poses": dict},
                      bodies={n: (p, (0.0, 0.0, 0.0, 1.0)) for n, p in where.items()})
    arm = Arm(radius)
    run.ctx.components["arm"] = arm  # type: ignore[index]
    found = [(p.key, p.message) for p in run.behaviour.preflight(run.ctx)]
    want = []
    target = (place[0], place[1], place[2] + 0.004)  # plus pick_place's place_clearance
    if math.dist(target, (0, 0, 0)) > radius:
        want.append(("behaviour.place_position", f"out of the reach of arm 'arm': unreachable: "
                     f"{math.dist(target, (0, 0, 0)):.3f} m from the base"))
    jobs = [(n, where[n], f"bodies.{n}") for n in names]
    jobs += [(None, p, f"behaviour.pick_positions[{i}]") for i, p in enumerate(positions)]
    for name, (x, y, z), key in jobs:
        d = math.dist((x, y, z), (0, 0, 0))
        if d > radius:
            what = f"{name} at" if name else "object at"  # named once where it lies
            want.append((key, f"{what} ({x:.3f}, {y:.3f}, {z:.3f}) is out of the reach of arm 'arm': "
                         f"unreachable: {d:.3f} m from the base"))
    assert found == want
