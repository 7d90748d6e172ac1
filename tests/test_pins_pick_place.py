"""pick_place's promises with expectations from its options: attempts with a cube that cannot be lifted, the
placement tolerance, a drop noticed while carrying, and the heights of the moves it commands (grasp_offset,
lift_height over the higher of pick and place, place_clearance, the release width)."""

from __future__ import annotations

import math
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


def test_an_approach_that_times_out_is_retried_with_the_move_sent_again() -> None:
    """The first approach (about 0.8 s at 0.8 m/s) overruns a 0.5 s APPROACH timeout. The retry re-enters APPROACH
    (a self-transition): the move above the cube is sent again, from where the arm is (a new arm command), and
    counted as attempt 2; it arrives inside the timeout and the cube is placed."""
    timeout, above = 0.5, 0.07  # APPROACH timeout, s; approach_height (grasp_offset 0), m
    seen: list[tuple[float, str, int, Any]] = []  # (t, state, arm command id, arm target) after each tick

    def note(sim: Any) -> bool:
        arm = sim.readings["arm"]
        seen.append((sim.world.time, sim.behaviour.state_name, arm.command_id, arm.target_position))
        return sim.outcome is not None

    with make_sim(CONFIG, overrides={"behaviour.speed": 0.8, "behaviour.timeouts": {"APPROACH": timeout}}) as sim:
        cube0 = sim.world.pose("cube")[0]
        assert sim.run_until(note, 240 * 20)
        cube = sim.world.pose("cube")[0]
        res, outcome = sim.behaviour.result(), sim.outcome
        moves = [(r["t"], r["source_state"], r["dest_state"]) for r in sim.trace
                 if r["kind"] == "transition" and r["machine"] == "behaviour"]
    assert moves[:3] == [(0.0, "WAIT", "APPROACH"), (pytest.approx(timeout, abs=0.01), "APPROACH", "APPROACH"),
                         (moves[2][0], "APPROACH", "DESCEND")]
    retried = moves[1][0]
    before = [s for s in seen if s[0] < retried and s[1] == "APPROACH"]
    after = [s for s in seen if retried < s[0] < moves[2][0]]
    assert before and after
    assert {s[2] for s in after} == {before[-1][2] + 1}  # one new arm command at the retry: the move, sent again
    # above the cube, located again (it settled by about a millimetre since it was spawned)
    assert after[0][3] == pytest.approx((cube0[0], cube0[1], cube0[2] + above), abs=0.002)
    assert moves[2][0] - retried < timeout  # the re-sent approach arrived within its own timeout
    assert outcome is not None and outcome.status == "succeeded"
    assert res["attempts"] == 2 and res["failures"] == [f"timed out in APPROACH after {timeout:g} s"]
    assert math.dist(cube[:2], (0.45, -0.35)) < 0.02  # configs/pick_place.toml's place_position, on the target
