"""pick_place's promises with expectations from its options: attempts with a cube that cannot be lifted, the
placement tolerance, a drop noticed while carrying, and the heights of the moves it commands (grasp_offset,
lift_height over the higher of pick and place, place_clearance, the release width)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from robokit_behaviours.pick_place import PickPlaceTask

from robokit.msgs.arm import GripperCommand, MoveTo
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "pick_place.toml"


def run(overrides: dict[str, Any]) -> Any:
    with make_sim(CONFIG, overrides=overrides) as sim:
        return sim.run()


@pytest.mark.parametrize("attempts", [1, 2])
def test_a_cube_that_cannot_be_lifted_uses_exactly_max_attempts(attempts: int) -> None:
    result = run({"bodies.cube.mass": 0.0, "behaviour.max_attempts": attempts})
    res = result.result
    assert result.outcome == "failed"
    assert res["attempts"] == attempts and len(res["failures"]) == attempts
    s = "s" if attempts > 1 else ""
    assert f"(after {attempts} attempt{s})" in result.reason
    assert res["failures"][-1].endswith(f"(after {attempts} attempt{s})")  # one entry per failed attempt


def test_a_placement_outside_place_tolerance_is_retried_not_accepted() -> None:
    """Released 4 cm above where it can rest, the cube lands 4 cm from place_position: more than the 2 cm
    tolerance, so the attempt fails."""
    result = run({"behaviour.place_position": [0.45, -0.35, 0.067], "behaviour.max_attempts": 1})
    res = result.result
    assert result.outcome == "failed"
    assert res["placement_error"] == pytest.approx(0.04, abs=0.006)
    assert res["failures"][0].startswith("placed 4")


def test_a_cube_lost_while_carrying_is_noticed_as_a_drop() -> None:
    with make_sim(CONFIG, overrides={"behaviour.max_attempts": 1}) as sim:
        for _ in range(4000):
            sim.step(1)
            if sim.behaviour.state_name == "TRANSPORT":
                break
        assert sim.behaviour.state_name == "TRANSPORT"
        sim.world.remove_body("cube")
        result = sim.run()
    assert result.result["failures"][0].startswith("dropped during TRANSPORT")


def test_move_heights_follow_the_options() -> None:
    """Pick at z 0.025, place higher at z 0.1; grasp_offset 0.01, lift 0.08, clearance 0.004, retreat 0.05."""
    opts = {"behaviour.grasp_offset": 0.01, "behaviour.lift_height": 0.08, "behaviour.place_clearance": 0.004,
            "behaviour.retreat_height": 0.05}
    with make_sim(CONFIG, overrides=opts) as sim:
        pp = sim.behaviour
        task = PickPlaceTask((0.5, 0.1, 0.025), 0.0, (0.45, -0.3, 0.1), None, 0.05)
        pp.start(task, 0.0)
        readings = sim.readings
        pp.enter_approach(readings)

        def z(commands: dict[str, Any]) -> float:
            move = commands["arm"]
            assert isinstance(move, MoveTo)
            return move.position[2]

        assert z(pp.enter_descend(readings)) == pytest.approx(0.025 + 0.01)
        assert z(pp.enter_lift(readings)) == pytest.approx(max(0.025, 0.1) + 0.01 + 0.08)
        assert z(pp.enter_transport(readings)) == pytest.approx(0.1 + 0.01 + 0.08)
        assert z(pp.enter_lower(readings)) == pytest.approx(0.1 + 0.01 + 0.004)
        assert z(pp.enter_retreat(readings)) == pytest.approx(0.1 + 0.01 + 0.05)
        release = pp.enter_release(readings)["gripper"]
        assert isinstance(release, GripperCommand) and release.width == pytest.approx(0.05 + 0.025)


def test_pick_place_time_inside_a_sort_counts_from_each_pick() -> None:
    """Inside the sort, each object's pick_place_time is its own job's time: together no more than the sort's."""
    overrides = {"bodies.red.count": 1, "bodies.blue.count": 1, "sensors.truth.bodies": ["red", "blue"]}
    with make_sim(ROOT / "configs" / "sort_robot.toml", overrides=overrides) as sim:
        res = sim.run().result
    times = [o["pick_place_time"] for o in res["objects"]]
    assert len(times) == 2 and all(t > 0.5 for t in times)
    assert sum(times) <= res["total_time"] + 1e-6
