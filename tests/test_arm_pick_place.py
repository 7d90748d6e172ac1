"""pick_place behaviour: a full friction pick-and-place, state order, retry after a drop, sub-machine use."""

from __future__ import annotations

import math
from pathlib import Path

from robokit_behaviours.pick_place import PickPlace, PickPlaceTask

from robokit.msgs.arm import cube_grasp_yaw
from robokit.testing import make_sim, states_visited

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"
CLEAN_RUN = ["APPROACH", "DESCEND", "GRASP", "LIFT", "TRANSPORT", "LOWER", "RELEASE", "RETREAT", "DONE"]


def test_pick_place_succeeds_with_friction_grasp_and_visits_states_in_order() -> None:
    with make_sim(CONFIG, seed=3) as sim:
        result = sim.run(max_time=6.0)
        assert result.outcome == "succeeded", result.reason
        assert states_visited(sim, "behaviour") == CLEAN_RUN
        res = result.result
        assert res["attempts"] == 1
        assert res["placement_error"] < 0.01
        assert math.dist(sim.world.pose("cube")[0], res["place_position"]) < 0.01
        assert res["sim_time"] < 3.0
        assert set(res["phase_times"]) >= {"APPROACH", "GRASP", "TRANSPORT", "RETREAT"}
        # friction grasp: nothing welds the cube to the hand
        assert sim.world.client.getNumConstraints() == 1  # only the finger gear


def test_drop_mid_transport_is_retried() -> None:
    with make_sim(CONFIG, seed=3) as sim:
        sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT", 2000)
        sim.step(20)
        assert sim.readings["gripper"].holding
        sim.world.set_pose("cube", (0.55, 0.05, 0.03))  # knocked out of the fingers onto the table
        result = sim.run(max_time=10.0)
        assert result.outcome == "succeeded", result.reason
        visited = states_visited(sim, "behaviour")
        first_transport = visited.index("TRANSPORT")
        assert visited[first_transport + 1] == "APPROACH"
        assert visited[-len(CLEAN_RUN):] == CLEAN_RUN
        assert result.result["attempts"] == 2
        assert result.result["failures"] == ["dropped during TRANSPORT"]


def test_sub_machine_contract_one_attempt() -> None:
    with make_sim(CONFIG, seed=5) as sim:
        pp = PickPlace.sub(name="pick_place", parent_ctx=sim.behaviour.ctx, arm="arm", gripper="gripper",
                           max_attempts=1)
        sim.behaviour.outcome = None
        sim.scheduler.behaviour = None  # the test drives the sub-machine directly
        pos, orn = sim.world.pose("cube")
        yaw = 2.0 * math.atan2(orn[2], orn[3])
        task = PickPlaceTask(pick_position=pos, pick_yaw=yaw, place_position=(0.45, -0.35, 0.027),
                             object_name="cube")
        pp.start(task, sim.world.time)
        for _ in range(2000):
            cmds = pp.step(sim.readings, sim.world.time) or {}
            for name, cmd in cmds.items():
                sim.components[name].command(cmd)
            if pp.outcome is not None:
                break
            sim.step(1)
        assert pp.outcome is not None and pp.outcome.status == "succeeded", pp.outcome
        assert math.dist(sim.world.pose("cube")[0], task.place_position) < 0.01
        assert pp.result()["attempts"] == 1
        assert "LIFT" in [r["dest_state"] for r in sim.trace if r.get("machine") == "pick_place"]
        # restart for a second job: the machine resets to its initial state
        pp.start(PickPlaceTask(sim.world.pose("cube")[0], 0.0, (0.45, -0.25, 0.027), "cube"), sim.world.time)
        assert pp.outcome is None and pp.state_name == "APPROACH"


def test_drop_with_no_attempts_left_fails_with_the_reason() -> None:
    with make_sim(CONFIG, seed=3, overrides={"behaviour.max_attempts": 1}) as sim:
        sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT", 2000)
        sim.step(20)
        sim.world.set_pose("cube", (0.55, 0.05, 0.03))
        result = sim.run(max_time=6.0)
        assert result.outcome == "failed"
        assert result.reason.startswith("goal not met: cube is ")
        assert result.reason.endswith("(the behaviour reported failed: dropped during TRANSPORT (after 1 attempt))")
        assert states_visited(sim, "behaviour")[-1] == "FAILED"


def test_unreachable_object_fails_at_once_with_the_arm_reason() -> None:
    with make_sim(CONFIG, seed=3) as sim:
        sim.world.set_pose("cube", (0.95, 0.45, 0.025))  # table corner, beyond the configured reach
        result = sim.run(max_time=6.0)
        assert result.outcome == "failed"
        assert result.reason.startswith("goal not met: cube is ")  # the world's verdict first (the outcome rule)
        assert "(the behaviour reported failed: arm failed in APPROACH: unreachable:" in result.reason
        assert result.sim_time < 0.1


def test_grasp_yaw_follows_the_cube_within_45_degrees() -> None:
    for cube_yaw in (0.0, 0.5, -0.7, 1.2, 3.0, -2.5):
        yaw = cube_grasp_yaw(cube_yaw, 0.0)
        assert abs(yaw) <= math.pi / 4 + 1e-9
        assert math.isclose(math.remainder(yaw - cube_yaw, math.pi / 2), 0.0, abs_tol=1e-9)


def _drop_noticed_after(hold_check_hz: float | None) -> int:
    """Ticks from knocking the cube out of the fingers mid-transport to the machine leaving TRANSPORT."""
    with make_sim(CONFIG, seed=3, overrides={"behaviour.hold_check_hz": hold_check_hz}) as sim:
        sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT", 2000)
        sim.step(21)
        sim.world.set_pose("cube", (0.55, 0.05, 0.03))
        start = sim.world.tick
        sim.run_until(lambda s: s.behaviour.state_name != "TRANSPORT", 200)
        assert sim.behaviour.failures == ["dropped during TRANSPORT"]
        return sim.world.tick - start


def test_a_drop_is_noticed_within_one_hold_check_period() -> None:
    assert _drop_noticed_after(None) <= 2  # checked every tick
    assert _drop_noticed_after(60.0) <= 240 // 60 + 1
    assert _drop_noticed_after(10.0) <= 240 // 10 + 1
    assert _drop_noticed_after(10.0) > _drop_noticed_after(None)


def test_the_arm_is_not_read_while_its_path_runs_and_the_result_is_unchanged() -> None:
    runs = {}
    for hz in (None, 60.0):
        with make_sim(CONFIG, seed=3, overrides={"behaviour.hold_check_hz": hz}) as sim:
            result = sim.run(max_time=6.0)
            assert result.outcome == "succeeded", result.reason
            runs[hz] = (result.sim_time, sim.readings.computed("arm"), sim.readings.computed("gripper"),
                        sim.world.tick, sim.world.pose("cube")[0])
    (time_a, arm_reads, grip_a, ticks, cube_a), (time_b, _, grip_b, _, cube_b) = runs[None], runs[60.0]
    assert time_a == time_b and cube_a == cube_b  # the same run, tick for tick
    assert arm_reads < ticks / 3  # read at the end of each path only (settling), not on every tick of it
    assert grip_b < grip_a  # fewer gripper reads while carrying
