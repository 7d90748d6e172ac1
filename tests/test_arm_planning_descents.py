"""The straight moves down and up at the cube and the bin, judged by the world (configs/pick_gap.toml).

The cube stands in a gap between two boxes too narrow for the fingers opened across it. Every tick the world is
asked for contacts of the arm and the cube with the boxes (and, in the last test, with a board over the bin); the
cube must end in the bin, or the job must stop at once with one line naming the cube and what is in the way."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from oracles import in_bin

from robokit.testing import make_sim

pytestmark = pytest.mark.slow

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pick_gap.toml"
OBSTACLES = ("box_left", "box_right", "board")


def run_watching(sim: Any, max_ticks: int = 4000) -> dict[str, Any]:
    """Run to the end; every contact of the arm or the cube with an obstacle along the way (tick time, who, what)."""
    w = sim.world
    robot, cube = w.body("panda"), w.body("cube")
    obstacles = {w.body(n): n for n in OBSTACLES if n in w.body_names}
    touches: list[tuple[float, str, str]] = []

    def watch(s: Any) -> bool:
        for who, name in ((robot, "panda"), (cube, "cube")):
            touches.extend((w.time, name, obstacles[c.other]) for c in w.contacts(who) if c.other in obstacles)
        return s.behaviour.outcome is not None

    sim.run_until(watch, max_ticks)
    return {"touches": touches, "outcome": sim.behaviour.outcome}


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_cube_is_taken_out_of_the_gap_turned_and_nothing_is_touched_on_the_way(engine: str) -> None:
    with make_sim(CONFIG, overrides={"world.engine": engine}) as sim:
        seen = run_watching(sim)
        assert seen["outcome"].status == "succeeded", seen["outcome"].reason
        assert seen["touches"] == []
        assert in_bin(sim.world, "cube")


def test_checking_only_the_links_up_to_the_wrist_lets_a_finger_hit_a_box() -> None:
    # the oracle sees what the check prevents: the same scene with the hand left out of the descent's check
    with make_sim(CONFIG, overrides={"behaviour.planning": {"check_descents": False}}) as sim:
        seen = run_watching(sim)
        assert any(who == "panda" and what.startswith("box_") for _, who, what in seen["touches"])
        assert not in_bin(sim.world, "cube")


def test_a_board_low_over_the_bin_stops_the_job_at_once_naming_it_and_nothing_is_driven_through() -> None:
    board = {"shape": "box", "size": [0.34, 0.14, 0.02], "mass": 0, "position": [0.5, -0.25, 0.17],
             "rgba": [0.6, 0.6, 0.65, 1]}
    with make_sim(CONFIG, overrides={"bodies.board": board}) as sim:
        (x0, y0, _), _ = sim.world.pose("cube")
        seen = run_watching(sim)
        outcome = seen["outcome"]
        assert outcome.status == "failed"
        assert "\n" not in outcome.reason
        assert outcome.reason.startswith("cube: no collision-free way in TRANSPORT")
        assert "board in the way" in outcome.reason
        assert seen["touches"] == []
        (x, y, _), _ = sim.world.pose("cube")  # lifted straight up in the gap, not carried anywhere
        assert abs(x - x0) < 0.01 and abs(y - y0) < 0.01
        assert sim.behaviour.attempts == 1


OBSTACLE = Path(__file__).resolve().parents[1] / "configs" / "pick_obstacle.toml"


def carry_while_a_box_comes_into_the_way(recheck_hz: float, replans: int = 0,
                                         size: tuple[float, float, float] = (0.08, 0.08, 0.08),
                                         at: tuple[float, float, float] = (0.5, -0.25, 0.2),
                                         engine: str = "pybullet") -> tuple[Any, int, int]:
    """configs/pick_obstacle.toml; 0.3 s into the transport a box is put ``at`` (over the bin: in the planned way).
    The outcome, the contacts of the arm or the cube with that box over the whole run, and the replans made."""
    box = {"shape": "box", "size": list(size), "mass": 0, "position": [1.5, 1.5, 0.04]}
    planning = {"recheck_hz": recheck_hz, "replans": replans}
    overrides = {"bodies.intruder": box, "behaviour.planning": planning, "world.engine": engine}
    with make_sim(OBSTACLE, overrides=overrides) as sim:
        w = sim.world
        robot, cube, intruder = w.body("panda"), w.body("cube"), w.body("intruder")
        moved, touches = [False], [0]

        def watch(s: Any) -> bool:
            if s.behaviour.state_name == "TRANSPORT" and s.behaviour.time_in_state > 0.3 and not moved[0]:
                w.set_pose("intruder", list(at))
                moved[0] = True
            touches[0] += sum(len(w.contacts(who, intruder)) for who in (robot, cube))
            return s.behaviour.outcome is not None

        sim.run_until(watch, 4000)
        assert moved[0]
        return sim.behaviour.outcome, touches[0], sim.behaviour.result()["planner"]["replans"]


def test_a_box_put_into_the_planned_way_stops_the_job_before_it_is_touched() -> None:
    outcome, touches, _ = carry_while_a_box_comes_into_the_way(10.0)
    assert outcome.status == "failed"
    assert outcome.reason == "cube: intruder came into the planned way in TRANSPORT; stopped"
    assert touches == 0


def test_without_rechecks_the_arm_carries_the_cube_into_the_box_that_came() -> None:
    outcome, touches, _ = carry_while_a_box_comes_into_the_way(0.0)
    assert touches > 0


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_with_replans_the_arm_goes_round_a_board_put_over_the_wall_and_places_the_cube(engine: str) -> None:
    # a board laid over the wall while the cube is carried across it: the rest of the way is planned again from
    # where the arm is, round the board; the world says nothing touched it and the cube is in the bin (on MuJoCo
    # the board, a static body, becomes movable by a recompile mid-carry: the cube stays held through it)
    outcome, touches, replans = carry_while_a_box_comes_into_the_way(10.0, replans=2, size=(0.22, 0.1, 0.03),
                                                                     at=(0.5, 0.02, 0.32), engine=engine)
    assert replans >= 1  # the board was in the way planned first
    assert outcome.status == "succeeded", outcome.reason
    assert touches == 0


def test_a_box_that_blocks_the_place_itself_fails_after_the_replans_naming_it() -> None:
    outcome, touches, replans = carry_while_a_box_comes_into_the_way(10.0, replans=2)
    assert replans == 1  # planned again once: no way into the bin while the box is over it
    assert outcome.status == "failed"
    assert outcome.reason.startswith("cube: no collision-free way in TRANSPORT"), outcome.reason
    assert "intruder" in outcome.reason and "\n" not in outcome.reason
    assert touches == 0


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_static_body_moved_far_away_mid_carry_changes_nothing_of_the_carry(engine: str) -> None:
    # moving a static body is a recompile on MuJoCo: what the fingers hold stays held through it
    outcome, touches, _ = carry_while_a_box_comes_into_the_way(0.0, at=(1.5, 1.3, 0.04), engine=engine)
    assert outcome.status == "succeeded", outcome.reason
    assert outcome.reason == "placed cube in 1 attempt(s)"
