"""sort's bookkeeping with a cube that cannot be picked (fixed to the table: the gripper closes on it and it stays
when the arm lifts), and its bins, counted by hand: attempts, failures, picks, the give-up and what follows it."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from robokit_behaviours.sort import Bin

from robokit.testing import make_sim

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "sort_robot.toml"
LOOK = (0.28, 0.0)  # the sort's default look_position (x, y): where the gripper is when it chooses


def stuck_red(**behaviour: Any) -> dict[str, Any]:
    """One red cube with mass 0 (static: it cannot be lifted) and one ordinary blue cube."""
    return {"bodies.red.mass": 0.0, "bodies.red.count": 1, "bodies.blue.count": 1,
            "sensors.truth.bodies": ["red", "blue"], **{f"behaviour.{k}": v for k, v in behaviour.items()}}


def run_sort(overrides: dict[str, Any]) -> tuple[Any, dict[str, tuple[float, float]], Any]:
    with make_sim(CONFIG, overrides=overrides) as sim:
        start = {n: tuple(sim.world.pose(n)[0][:2]) for n in ("red", "blue")}
        bins = sim.behaviour.bins
        result = sim.run()
        result.behaviour_status = sim.behaviour.outcome.status  # the sort's own verdict (the run's is the goal's)
    return result, start, bins


@pytest.mark.slow
@pytest.mark.parametrize("attempts", [1, 2, 3])
def test_an_unpickable_cube_is_tried_max_attempts_times_then_given_up(attempts: int) -> None:
    result, _, _ = run_sort(stuck_red(max_attempts=attempts))
    res = result.result
    red = next(o for o in res["objects"] if o["colour"] == "red")
    blue = next(o for o in res["objects"] if o["colour"] == "blue")
    assert red["attempts"] == attempts and red["outcome"] == "failed" and red["reason"]
    assert blue["attempts"] == 1 and blue["outcome"] == "sorted"
    assert res["failures"] == attempts  # one per failed attempt
    assert res["picks"] == attempts + 1  # and nothing more: the given-up cube is left alone
    assert res["blue_sorted"] == 1 and res["red_sorted"] == 0
    assert result.behaviour_status == "failed"  # an object was given up: the sort does not claim success


def test_max_picks_ends_the_sort_after_exactly_that_many_picks() -> None:
    result, _, _ = run_sort(stuck_red(max_attempts=5, max_picks=2))
    assert result.result["picks"] == 2
    assert result.behaviour_status == "failed" and "2 pick attempts used up" in result.reason


def test_the_first_pick_is_the_object_nearest_the_gripper() -> None:
    """With the gripper at the look position, the first object picked is the nearer cube (by the true poses)."""
    result, start, _ = run_sort(stuck_red(max_attempts=1))
    nearest = min(start, key=lambda n: math.dist(start[n], LOOK))
    assert result.result["objects"][0]["body"] == nearest


def test_place_slots_sit_an_object_half_height_above_the_bin_floor() -> None:
    with make_sim(CONFIG) as sim:
        bins = sim.behaviour.bins
        floor = {c: sim.world.pose(b.body)[0][2] + 0.008 for c, b in bins.items()}  # bin base + BinConfig.floor
        centre = {c: sim.world.pose(b.body)[0][:2] for c, b in bins.items()}
    for colour, b in bins.items():
        assert {round(s[2], 9) for s in b.slots} == {round(floor[colour] + 0.025, 9)}
        d = 0.07 / 2  # slot_spacing / 2
        want = {(round(centre[colour][0] + ox, 9), round(centre[colour][1] + oy, 9))
                for ox, oy in [(-d, -d), (d, d), (-d, d), (d, -d), (0, 0)]}
        assert {(round(s[0], 9), round(s[1], 9)) for s in b.slots} == want


def make_bin() -> Bin:
    slots = [(float(i), 0.0, 0.1) for i in range(5)]
    return Bin("red", "red_bin", slots, low=(0.0, 0.0), high=(0.3, 0.2), top=0.08)


def test_next_slot_cycles_through_every_slot() -> None:
    b = make_bin()
    assert [b.next_slot()[0] for _ in range(7)] == [0.0, 1.0, 2.0, 3.0, 4.0, 0.0, 1.0]


def test_holds_needs_the_footprint_and_below_the_rim() -> None:
    b = make_bin()
    assert b.holds((0.1, 0.1, 0.05))
    assert not b.holds((0.1, 0.1, 0.09))  # on the rim, above its top
    assert not b.holds((0.35, 0.1, 0.05)) and not b.holds((0.1, -0.01, 0.05))


def test_contains_grows_the_footprint_by_the_margin_on_every_side() -> None:
    b = make_bin()
    for x, y in [(-0.015, 0.1), (0.315, 0.1), (0.1, -0.015), (0.1, 0.215)]:
        assert b.contains(x, y, 0.02) and not b.contains(x, y, 0.01)


def test_a_new_cube_near_a_given_up_one_is_a_new_object() -> None:
    """The unpickable red cube is given up after its one attempt; a second red cube 10 cm beyond it (outside the
    given-up zone of 5 cm, inside the 15 cm 'same object' radius) is a new object: picked and sorted on its own."""
    with make_sim(CONFIG, overrides=stuck_red()) as sim:
        stuck = sim.world.pose("red")[0]
    away = (stuck[0] - LOOK[0], stuck[1] - LOOK[1])
    norm = math.hypot(*away)
    second = [stuck[0] + 0.1 * away[0] / norm, stuck[1] + 0.1 * away[1] / norm, 0.025]
    overrides = {**stuck_red(max_attempts=1), "bodies.red2": {
        "shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": second, "rgba": [0.9, 0.1, 0.1, 1],
        "lateral_friction": 1.0}}
    result, _, _ = run_sort(overrides)
    reds = [o for o in result.result["objects"] if o["colour"] == "red"]
    assert [(o["outcome"], o["attempts"]) for o in reds] == [("failed", 1), ("sorted", 1)]
    assert result.result["red_sorted"] == 1 and result.result["picks"] == 3
