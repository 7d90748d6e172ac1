"""Collision-free arm motion judged by the world: a wall between cube and bin (configs/pick_obstacle.toml).

Every tick the world is asked for contacts of the arm and the cube with the wall; the cube must end in the bin. The
planner's path is checked again, finer and without the margin, by PyBullet's own closest-point query on a fresh
build (not by the planner's ``World.clashes``)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomllib
from oracles import in_bin

from robokit.planning.rrt import densify
from robokit.testing import edited_config, make_sim, validate_error

pytestmark = pytest.mark.slow

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pick_obstacle.toml"
SORT = Path(__file__).resolve().parents[1] / "configs" / "sort_robot.toml"
ROOT_PICK = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"


def run_watching_the_wall(sim: Any, max_ticks: int = 4000) -> dict[str, Any]:
    """Run to the end; per tick, every contact of the arm or the cube with the wall, and each command sent to the
    arm when it is a joint-space path."""
    w = sim.world
    wall, cube, robot = w.body("wall"), w.body("cube"), w.body("panda")
    seen: dict[str, Any] = {"touches": [], "paths": [], "carried": []}

    def watch(s: Any) -> bool:
        for who in (robot, cube):
            seen["touches"] += [(w.time, who) for _ in w.contacts(who, wall)]
        moves = s.behaviour.moves
        if moves is not None and moves.last is not None and moves.last is not seen.get("plan"):
            seen["plan"] = moves.last
            if moves.last.path is not None and not moves.last.straight:
                seen["paths"].append(moves.last.path)
                seen["carried"].append(list(moves.planner.carried))
        return s.behaviour.outcome is not None

    sim.run_until(watch, max_ticks)
    seen["outcome"] = sim.behaviour.outcome
    return seen


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_planner_carries_the_cube_round_the_wall_into_the_bin(engine: str) -> None:
    with make_sim(CONFIG, overrides={"world.engine": engine}) as sim:
        seen = run_watching_the_wall(sim)
        assert seen["outcome"].status == "succeeded", seen["outcome"].reason
        assert seen["touches"] == []
        assert in_bin(sim.world, "cube")
        stats = sim.behaviour.result()["planner"]
        assert stats["planned"] >= 1 and stats["failed"] == 0  # the transport went round, the rest was straight
        assert stats["straight"] >= 1


def test_the_posture_over_the_bin_keeps_the_elbow_clear_on_the_way_down() -> None:
    """Three boxes between cube and bin, the last one close to the bin: the posture the straight transport would end
    in brings the elbow down onto that box as the hand lowers the cube into the bin; the planner takes another."""
    cfg = tomllib.loads(CONFIG.read_text(encoding="utf-8"))
    bodies = cfg["bodies"]
    del bodies["wall"]
    bodies["cube"].update(position=[0.598, 0.227, 0.025], rpy_deg=[0, 0, -21.8])
    bodies["bin"]["position"] = [0.455, -0.272, 0]
    cfg["behaviour"]["place_position"] = [0.455, -0.272, 0.03]
    for i, (side, (x, y), height) in enumerate([(0.071, (0.527, 0.028), 0.202), (0.064, (0.502, -0.022), 0.16),
                                                 (0.061, (0.434, -0.072), 0.25)]):
        bodies[f"wall_{i}"] = {"shape": "box", "size": [side, side, height], "mass": 0,
                               "position": [x, y, height / 2]}
    with make_sim(cfg, base_dir=CONFIG.parent) as sim:
        w = sim.world
        boxes = {w.body(f"wall_{i}") for i in range(3)}
        touches: list[tuple[float, str]] = []

        def watch(s: Any) -> bool:
            for who in ("panda", "cube"):
                touches.extend((w.time, who) for c in w.contacts(w.body(who)) if c.other in boxes)
            return s.behaviour.outcome is not None

        sim.run_until(watch, 4800)
        assert sim.behaviour.outcome.status == "succeeded", sim.behaviour.outcome.reason
        assert touches == [] and in_bin(w, "cube")


def test_straight_lines_drive_the_arm_into_the_wall() -> None:
    with make_sim(CONFIG, overrides={"behaviour.planner": "straight"}) as sim:
        seen = run_watching_the_wall(sim)
        assert seen["touches"], "the scene must block the straight way"
        assert seen["outcome"].status == "failed"
        assert not in_bin(sim.world, "cube")


def test_the_planned_path_is_free_at_a_fine_step_on_a_fresh_build_and_the_same_for_a_seed() -> None:
    runs = []
    for _ in range(2):
        with make_sim(CONFIG) as sim:
            seen = run_watching_the_wall(sim)
            runs.append((seen["paths"], seen["carried"], sim.world.pose("cube")))
    (paths, carried, final), (paths2, _, final2) = runs
    assert paths and len(paths) == len(paths2)
    assert all(np.array_equal(a, b) for a, b in zip(paths, paths2, strict=True)) and final == final2
    with make_sim(CONFIG) as sim:  # nothing stepped: the arm is put at each configuration by hand
        w, c = sim.world, sim.world.client
        robot, wall, arm = w.body("panda"), w.body("wall"), sim.behaviour.ctx.components["arm"]
        joints = [j.index for j in arm.arm]
        for path, held in zip(paths, carried, strict=True):
            fine = densify(list(path), 0.005)
            assert len(fine) > len(path)
            for q in fine:
                for j, v in zip(joints, q, strict=True):
                    c.resetJointState(robot, j, float(v))
                assert c.getClosestPoints(robot, wall, 0.0) == ()
                for body, link, (pos, orn) in held:
                    c.resetBasePositionAndOrientation(body, *c.multiplyTransforms(*w.pose(robot, link), pos, orn))
                    assert c.getClosestPoints(body, wall, 0.0) == ()


def test_a_path_goes_to_the_arm_as_joint_targets_it_then_reaches() -> None:
    with make_sim(CONFIG) as sim:
        sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT", 3000)
        moves = sim.behaviour.moves
        assert moves.last is not None and not moves.last.straight
        arm = sim.behaviour.ctx.components["arm"]
        goal = moves.last.path[-1]
        assert sim.run_until(lambda s: s.behaviour.state_name == "LOWER", 3000)  # the arm reported: reached
        measured = [s[0] for s in sim.world.joint_states(arm.body, [j.index for j in arm.arm])]
        assert np.max(np.abs(np.array(measured) - goal)) < 0.02


def test_with_the_way_clear_the_sort_takes_every_straight_line_and_sorts_as_before() -> None:
    with make_sim(SORT, overrides={"behaviour.planner": "rrt"}) as sim:
        planned = sim.run(max_time=40.0)
    with make_sim(SORT) as sim:
        straight = sim.run(max_time=40.0)
    assert planned.outcome == straight.outcome == "succeeded", planned.reason
    stats = planned.result["planner"]
    assert stats["moves"] >= 4 and stats["planned"] == 0 and stats["failed"] == 0 and stats["samples"] == 0
    for key in ("red_sorted", "blue_sorted", "failures"):
        assert planned.result[key] == straight.result[key]


@pytest.mark.parametrize(("old", "new", "expected"), [
    ('\nplanner = "rrt"', '\nplanner = "rtt"', r"behaviour\.planner: input should be 'straight' or 'rrt', got 'rtt'$"),
    ('\nplanner = "rrt"', '\nplanner = "rrt"\nplanning = { margin = -0.01 }',
     r"behaviour\.planning\.margin: input should be greater than or equal to 0"),
])
def test_a_bad_planner_setting_is_one_line(tmp_path: Path, old: str, new: str, expected: str) -> None:
    line = validate_error(edited_config(CONFIG, tmp_path, old, new))
    assert "\n" not in line and re.search(expected, line), line


def test_the_wall_really_stands_between_cube_and_bin() -> None:
    with make_sim(CONFIG) as sim:
        w = sim.world
        cube, bin_centre = w.pose("cube")[0], w.pose("bin")[0]
        lo, hi = w.body_aabb("wall")
        assert cube[1] > hi[1] and bin_centre[1] < lo[1] and lo[0] < cube[0] < hi[0]
        assert hi[2] > cube[2] + 0.08 + 0.05  # taller than the straight transport altitude plus the cube
        assert math.isclose(cube[0], bin_centre[0])


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_asking_about_configurations_leaves_the_run_exactly_as_it_would_have_been(engine: str) -> None:
    """World.clashes mid-transport (the arm elsewhere, the cube in its fingers) changes nothing that follows."""
    finals = []
    for calls in (0, 5):
        with make_sim(ROOT_PICK, seed=3, overrides={"world.engine": engine}) as sim:
            w, arm = sim.world, sim.behaviour.ctx.components["arm"]
            robot, cube, joints = w.body("panda"), w.body("cube"), [j.index for j in arm.arm]
            assert sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT", 3000)
            sim.step(5)
            q = [s[0] for s in w.joint_states(robot, joints)]
            held = w.multiply_transforms(*w.invert_transform(*w.pose(robot, arm.ee)), *w.com_pose(cube))
            for k in range(calls):
                w.clashes(robot, joints, [v + 0.1 * (k + 1) for v in q], carried=[(cube, arm.ee, held)], margin=0.01)
            sim.step(300)
            finals.append((w.pose("cube"), [s[:2] for s in w.joint_states(robot, joints)]))
    assert finals[0] == finals[1]


def test_the_arm_follows_a_joint_path_and_refuses_a_bad_one() -> None:
    from robokit.msgs.arm import FollowJoints

    scene = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
             "actuators": {"arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget",
                                   "ready_pose": {"panda_joint2": -0.4, "panda_joint4": -2.2,
                                                  "panda_joint6": 1.8, "panda_joint7": 0.785}}}}
    with make_sim(scene) as sim:
        arm, w = sim.components["arm"], sim.world
        names = tuple(j.name for j in arm.arm)
        start = np.array(arm.q_cmd)
        path = [start + np.array([0.3, 0.1, 0, 0.2, 0, -0.1, 0]) * k / 4 for k in range(1, 5)]
        arm.command(FollowJoints(names, tuple(tuple(q) for q in path)))
        assert sim.run_until(lambda s: s.readings["arm"].reached, 2000)
        measured = np.array([s[0] for s in w.joint_states(arm.body, [j.index for j in arm.arm])])
        assert np.max(np.abs(measured - path[-1])) < 0.01
        arm.command(FollowJoints(("panda_joint9",), ((0.0,),)))
        assert sim.run_until(lambda s: s.readings["arm"].failed, 5)
        assert "unknown arm joint 'panda_joint9'" in sim.readings["arm"].reason
        arm.command(FollowJoints(names[:1], ((9.0,),)))
        sim.step(1)
        assert sim.readings["arm"].failed and "outside the joint limits" in sim.readings["arm"].reason
