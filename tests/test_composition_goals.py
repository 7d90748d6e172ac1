"""When a goal is checked, on real physics: a child's goal is judged when that child ends; the run's final verdict
asks the world only about what must last (the last step of a sequence, the alternative that succeeded, a child
marked ``must_last``).

Every test judges by the world: the cubes' poses, read from the World when a step ends and when the run ends, and
compared with the bins' boxes and the place spots by plain geometry (not by the behaviours' goal checks).
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from robokit.checks.scripted import ScriptedRun
from robokit.components import Behaviour, GoalCheck
from robokit.config import read_toml
from robokit.core.composites import (
    Fallback,
    FallbackConfig,
    Member,
    Parallel,
    ParallelConfig,
    Retry,
    RetryConfig,
    Sequence,
    SequenceConfig,
)
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
STAGING = [0.55, 0.26, 0.027]
"""Where the sequence's first step puts red_0: on the table, in the camera's view, clear of the scattered cubes."""
TOLERANCE = 0.02
"""m: pick_place's default place tolerance."""

SORT = read_toml(CONFIGS / "sort_robot.toml")
PICK = read_toml(CONFIGS / "pick_place.toml")


def stage_then_sort(must_last: bool = False) -> dict[str, Any]:
    """configs/sort_robot.toml with its task a sequence: pick_place red_0 to a staging spot, then sort."""
    raw = copy.deepcopy(SORT)
    sort = {"name": "sort", **raw["behaviour"]}
    move: dict[str, Any] = {"type": "pick_place", "name": "move_red", "arm": "arm", "gripper": "gripper",
                            "pose_sensor": "truth", "object": "red_0", "object_size": 0.05,
                            "place_position": STAGING}
    if must_last:
        move["must_last"] = True
    raw["behaviour"] = {"type": "sequence", "steps": [move, sort]}
    raw["world"]["max_time"] = 60.0
    return raw


def suction_then_fingers() -> dict[str, Any]:
    """configs/pick_place.toml with a suction cup on the Panda's palm and a fallback: the cup first (to one spot),
    the fingers second (to another). The palm is above the fingertips, so the cup never touches the cube."""
    raw = copy.deepcopy(PICK)
    raw["actuators"]["cup"] = {"type": "suction", "body": "panda", "link": "panda_hand"}
    common = {"type": "pick_place", "arm": "arm", "pose_sensor": "poses", "object": "cube", "max_attempts": 1}
    raw["behaviour"] = {"type": "fallback", "children": [
        {**common, "name": "suction", "gripper": "cup", "place_position": [0.6, -0.3, 0.027]},
        {**common, "name": "fingers", "gripper": "gripper", "place_position": [0.45, -0.35, 0.027]}]}
    return raw


def in_box(world: Any, body: str, box: str) -> bool:
    """The body's centre lies inside the box body's axis-aligned bounds (x, y) and below its top (z)."""
    (x, y, z), _ = world.pose(body)
    (lx, ly, _lz), (hx, hy, hz) = world.body_aabb(box)
    return lx <= x <= hx and ly <= y <= hy and z <= hz


def ended(sim: Any, kind: str, name: str) -> bool:
    return any(r["kind"] == kind and name in (r.get("step"), r.get("child")) for r in sim.trace)


def sequence_run(seed: int) -> None:
    with make_sim(stage_then_sort(), base_dir=CONFIGS, seed=seed) as sim:
        assert sim.run_until(lambda s: ended(s, "step_end", "move_red"), 240 * 30)
        staged = sim.world.pose("red_0")[0]
        result = sim.run()
        bins = {name: f"{name.split('_')[0]}_bin" for name in ("red_0", "red_1", "blue_0", "blue_1")}
        sorted_ = {name: in_box(sim.world, name, box) for name, box in bins.items()}
    # the world when the first step ended: red_0 on the staging spot
    assert math.dist(staged, STAGING) <= TOLERANCE
    # the world at the end: every cube in its bin (red_0 moved on, rightly)
    assert all(sorted_.values()), sorted_
    assert result.outcome == "succeeded", result.reason
    move, sort = result.result["steps"]
    assert move["outcome"] == "succeeded" and move["goal"]["met"] is True  # judged when it ended
    assert sort["goal"]["met"] is True
    assert list(result.result["goal"]["steps"]) == ["sort"]  # the final verdict: the last step only


def test_a_sequence_that_stages_a_cube_then_sorts_succeeds_when_every_cube_is_in_its_bin() -> None:
    sequence_run(0)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_stage_then_sort_on_more_seeds(seed: int) -> None:
    sequence_run(seed)


def test_a_step_marked_must_last_is_asked_again_at_the_end_and_the_world_says_it_did_not_last() -> None:
    with make_sim(stage_then_sort(must_last=True), base_dir=CONFIGS, seed=0) as sim:
        result = sim.run()
        moved = math.dist(sim.world.pose("red_0")[0], STAGING)
    assert moved > 0.1  # the sort took red_0 to its bin: the staging did not last
    assert result.outcome == "failed"
    assert result.reason.startswith("goal not met: move_red: red_0 is ")
    assert result.result["steps"][0]["goal"]["met"] is True  # it held when the step ended
    assert set(result.result["goal"]["steps"]) == {"sort", "move_red"}


def fallback_run(seed: int) -> None:
    with make_sim(suction_then_fingers(), base_dir=CONFIGS, seed=seed) as sim:
        result = sim.run()
        final = sim.world.pose("cube")[0]
    assert math.dist(final, [0.45, -0.35, 0.027]) <= TOLERANCE  # the fingers' spot
    assert math.dist(final, [0.6, -0.3, 0.027]) > 0.1  # not the cup's
    assert result.outcome == "succeeded", result.reason
    suction, fingers = result.result["children"]
    assert suction["outcome"] == "failed" and suction["goal"]["met"] is False
    assert fingers["outcome"] == "succeeded" and fingers["goal"]["met"] is True
    assert list(result.result["goal"]["children"]) == ["fingers"]  # the abandoned alternative is not the verdict


def test_a_fallback_is_judged_by_the_alternative_that_succeeded() -> None:
    fallback_run(0)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_suction_then_fingers_on_more_seeds(seed: int) -> None:
    fallback_run(seed)


@pytest.mark.slow  # a whole sort with a camera: seconds
def test_a_later_sort_step_counts_only_its_own_camera_frames() -> None:
    raw = copy.deepcopy(SORT)
    sort = {"name": "sort", **raw["behaviour"]}
    look = {"type": "record", "name": "look", "components": ["camera"], "duration": 0.5, "rate_hz": 30}
    raw["behaviour"] = {"type": "sequence", "steps": [look, sort]}
    with make_sim(raw, base_dir=CONFIGS, seed=0) as sim:
        result = sim.run()
        renders = sim.readings.computed("camera")  # the camera's own count, the whole run
    recorded, sorted_ = (s["result"] for s in result.result["steps"])
    assert recorded["recorded"]["camera"] == 16  # 0.5 s at 30 Hz, both ends included
    assert sorted_["camera_frames"] == sorted_["looks"] == renders - 16



# ---------------------------------------------------------------------------------------------- the rule, scripted
WORLD: dict[str, bool] = {}
"""The scripted world's truth: is each probe's goal met now (a stand-in for the poses a goal check reads)."""


class Claim(Behaviour):
    """Claims ``succeeded`` or ``failed`` at its first step, as the script says; its goal is ``WORLD[name]``."""

    def __init__(self, name: str, config: Any = None) -> None:
        super().__init__(name, config)
        self.claim = "succeeded"

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        self.finish(readings.get(self.name, self.claim), f"{self.name} claims")

    def check_goal(self, world: Any) -> GoalCheck:
        return GoalCheck(WORLD[self.name], f"{self.name} {'met' if WORLD[self.name] else 'missed'}")

    def result(self) -> dict[str, Any]:
        return {"mine": self.name}


def scripted(composite: Any, names: list[str], truth: dict[str, bool]) -> tuple[ScriptedRun, Any]:
    WORLD.clear()
    WORLD.update(truth)
    composite.add_children([Member.of(Claim(n)) for n in names])
    run = ScriptedRun(composite)
    for _ in range(20):
        if run.outcome is not None:
            break
        run.step({})
    return run, composite


def test_every_combination_of_claims_and_goals_gives_the_rule() -> None:
    """Sequence and fallback of two, each child claiming succeeded/failed with its goal met or not: the judged
    outcome of a child is its goal (met: succeeded), and the composite's rule applies to the judged outcomes."""
    for claims in itertools.product(("succeeded", "failed"), repeat=2):
        for goals in itertools.product((True, False), repeat=2):
            truth = dict(zip(("a", "b"), goals, strict=True))
            for kind, cls, cfg in (("sequence", Sequence, SequenceConfig), ("fallback", Fallback, FallbackConfig)):
                comp = cls("c", cfg())
                comp.add_children([Member.of(Claim(n)) for n in "ab"])
                for m, claim in zip(comp.children, claims, strict=True):
                    m.behaviour.claim = claim
                WORLD.clear()
                WORLD.update(truth)
                run = ScriptedRun(comp)
                for _ in range(5):
                    if run.outcome is None:
                        run.step({})
                judged = list(goals)  # by hand: a child's judged outcome is its goal
                expected = all(judged) if kind == "sequence" else any(judged)
                assert (run.outcome.status == "succeeded") == expected, (kind, claims, goals)
                ran = 1 + (judged[0] if kind == "sequence" else not judged[0])
                records = comp.result()["steps" if kind == "sequence" else "children"]
                assert [r["outcome"] for r in records[:ran]] == [
                    "succeeded" if g else "failed" for g in judged[:ran]]
                assert all(r["goal"]["met"] == g for r, g in zip(records, judged[:ran], strict=False))


def test_a_retry_goes_by_its_last_attempt_and_every_attempt_keeps_its_result() -> None:
    run, comp = scripted(Retry("r", RetryConfig(attempts=3)), ["a"], {"a": False})
    assert run.outcome.status == "failed" and comp.attempt == 3  # claimed success three times, never met
    records = comp.result()["children"]
    assert [r["outcome"] for r in records] == ["failed"] * 3
    assert [r["result"] for r in records] == [{"mine": "a"}] * 3
    assert all(r["claimed"]["outcome"] == "succeeded" for r in records)


def test_a_parallel_goes_by_its_policy_on_judged_outcomes_and_the_verdict_asks_the_winners() -> None:
    run, comp = scripted(Parallel("p", ParallelConfig(success="one", failure="all")), ["a", "b"],
                         {"a": False, "b": True})
    assert run.outcome.status == "succeeded"
    WORLD["b"] = False  # b's effect did not last
    check = comp.check_goal(None)
    assert check is not None and not check.met and list(check.details["children"]) == ["b"]

