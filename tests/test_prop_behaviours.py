"""The behaviours' verdicts and records judged by the world: pick_place's goal (the object rests on the place spot
within place_tolerance) against the cube's pose and speed as the world has them, one object or a stack; patrol's
visits against where the robot is, per-leg timeouts against the sim clock, its trace against its result, the distance
it reports against the path it drove, and the stop it leaves the drive in."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from robokit.errors import ConfigError
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
PICK_PLACE = ROOT / "configs" / "pick_place.toml"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_pins_patrol import room  # noqa: E402  (the walled room of patrol's pins, without the box)

PLACE = (0.45, -0.35, 0.027)  # pick_place.toml's place_position
TOLERANCE = 0.02  # pick_place.toml leaves place_tolerance at its documented default, 2 cm
CUBE = 0.05


@pytest.mark.slow
def test_pick_place_goal_is_the_cube_at_rest_within_tolerance_of_the_place_spot() -> None:
    """40 cube poses around the place spot, each set in the world: met exactly when the distance the test computes
    from the pose the world reports is within the tolerance; a falling cube is not placed until it has landed."""
    rng = np.random.default_rng(38)
    with make_sim(PICK_PLACE) as sim:
        world, pick = sim.world, sim.behaviour
        seen = set()
        for _ in range(40):
            offset = (*rng.uniform(-0.03, 0.03, 2), rng.uniform(0.0, 0.03))
            world.set_pose("cube", [p + o for p, o in zip(PLACE, offset, strict=True)], [0, 0, 0, 1])
            pos = world.pose("cube")[0]
            error = math.dist(pos, PLACE)
            if abs(error - TOLERANCE) < 1e-4:
                continue
            check = pick.check_goal(world)
            assert check.met == (error <= TOLERANCE), (offset, error, check)
            assert check.details["placement_error"] == pytest.approx(error, abs=1e-5)
            assert not check.details["touching_robot"]
            seen.add(check.met)
        assert seen == {True, False}
        # released 12 mm above the spot: within the tolerance but falling, then landed and still
        world.set_pose("cube", [PLACE[0], PLACE[1], PLACE[2] + 0.012], [0, 0, 0, 1])
        for _ in range(7):
            world.step()
        assert math.hypot(*world.velocity("cube")[0]) > 0.2 and math.dist(world.pose("cube")[0], PLACE) < TOLERANCE
        assert not pick.check_goal(world).met
        for _ in range(240):
            world.step()
        assert math.hypot(*world.velocity("cube")[0]) < 0.01
        assert pick.check_goal(world).met


@pytest.mark.slow
def test_pick_place_goal_with_several_objects_is_every_one_on_the_spot_a_stack_any_height() -> None:
    """Two cubes: on the spot means horizontally within the tolerance of it (the second may rest on the first);
    one of them off the spot, or gone from the world, and the goal is not met."""
    cube2 = {"shape": "box", "size": [CUBE] * 3, "mass": 0.1, "position": [0.6, 0.1, CUBE / 2]}
    rng = np.random.default_rng(7)
    with make_sim(PICK_PLACE, overrides={"bodies.cube2": cube2, "behaviour.objects": ["cube", "cube2"],
                                         "behaviour.object": None}) as sim:
        world, pick = sim.world, sim.behaviour
        for _ in range(12):
            shifts = rng.uniform(-0.03, 0.03, (2, 2))
            for k, (name, shift) in enumerate(zip(("cube", "cube2"), shifts, strict=True)):
                world.set_pose(name, [PLACE[0] + shift[0], PLACE[1] + shift[1], PLACE[2] + k * (CUBE + 0.002)],
                               [0, 0, 0, 1])
            errors = [math.dist(world.pose(n)[0][:2], PLACE[:2]) for n in ("cube", "cube2")]
            if any(abs(e - TOLERANCE) < 1e-4 for e in errors):
                continue
            check = pick.check_goal(world)
            assert check.met == all(e <= TOLERANCE for e in errors), (errors, check)
            assert [o["object"] for o in check.details["objects"]] == ["cube", "cube2"]
        for k, name in enumerate(("cube", "cube2")):
            world.set_pose(name, [PLACE[0], PLACE[1], PLACE[2] + k * (CUBE + 0.002)], [0, 0, 0, 1])
        assert pick.check_goal(world).met
        world.remove_body("cube2")
        assert not pick.check_goal(world).met


@pytest.mark.slow
def test_pick_place_goal_is_not_met_while_the_cube_touches_the_robot() -> None:
    """The robot's base pushed against the cube on the place spot: the cube rests within the tolerance, still, but
    touches the robot (the world's contact points say so): not placed. The robot moved away: placed."""
    with make_sim(PICK_PLACE) as sim:
        world, pick = sim.world, sim.behaviour
        base_lo = world.aabb("panda", -1)[0]
        world.set_pose("cube", list(PLACE), [0, 0, 0, 1])
        world.set_pose("panda", [PLACE[0] + CUBE / 2 - base_lo[0] - 0.01, PLACE[1], 0.0])
        for _ in range(240):
            world.step()
        assert world.contacts(world.body("cube"), world.body("panda"))
        assert math.dist(world.pose("cube")[0], PLACE) < TOLERANCE and math.hypot(*world.velocity("cube")[0]) < 0.01
        check = pick.check_goal(world)
        assert not check.met and check.details["touching_robot"]
        world.set_pose("panda", [0, 0, 0])
        for _ in range(10):
            world.step()
        assert not world.contacts(world.body("cube"), world.body("panda"))
        assert pick.check_goal(world).met


@pytest.mark.slow
@pytest.mark.parametrize("by", ["objects", "pick_positions"])
def test_pick_place_stacks_objects_in_the_order_given_by_name_or_by_position(by: str) -> None:
    """Two cubes stacked on the place spot in the order the jobs name them, or the order of the positions given
    (each object identified by where it lies): the world has the first at the place height and the second one cube
    higher, both on the spot."""
    cube2 = {"shape": "box", "size": [CUBE] * 3, "mass": 0.1, "position": [0.6, 0.1, CUBE / 2],
             "lateral_friction": 0.8}
    overrides = {"bodies.cube2": cube2, "behaviour.object": None, "sensors.poses.bodies": ["cube", "cube2"],
                 "world.max_time": 40}
    with make_sim(PICK_PLACE, overrides={**overrides, "behaviour.objects": ["cube", "cube2"]}) as probe:
        starts = {n: list(probe.world.pose(n)[0]) for n in ("cube", "cube2")}
    order = ["cube2", "cube"] if by == "pick_positions" else ["cube", "cube2"]
    jobs = {"behaviour.pick_positions": [starts[n] for n in order]} if by == "pick_positions" else \
        {"behaviour.objects": order}
    with make_sim(PICK_PLACE, overrides={**overrides, **jobs}) as sim:
        result = sim.run()
        assert result.outcome == "succeeded", result.reason
        for level, name in enumerate(order):
            pos = sim.world.pose(name)[0]
            assert math.dist(pos[:2], PLACE[:2]) < TOLERANCE
            assert pos[2] == pytest.approx(PLACE[2] + level * CUBE, abs=0.01)
        jobs = result.result["jobs"]
        assert [job["object"] for job in jobs] == order and result.result["placed"] == len(order)
        assert all(job["outcome"] == "succeeded" and job["reason"].startswith(f"placed {job['object']} in ")
                   for job in jobs)
        attempts = sum(job["attempts"] for job in jobs)  # the reason's figure is the jobs' records summed
        assert sim.behaviour.outcome.reason == f"placed {len(order)} objects in {attempts} attempt(s)"
        assert sim.behaviour.check_goal(sim.world).met
        sim.world.set_pose(order[0], [0.6, 0.2, CUBE / 2], [0, 0, 0, 1])  # the first one taken off the spot
        check = sim.behaviour.check_goal(sim.world)
        assert not check.met and order[0] in check.reason


@pytest.mark.slow
def test_pick_place_by_a_position_alone_judges_the_object_it_found_there() -> None:
    """One job given only by where the cube lies: before it starts the goal cannot name an object; after the run
    the cube it found there rests on the spot (the world), and taken off it the goal is not met."""
    with make_sim(PICK_PLACE) as probe:
        start = list(probe.world.pose("cube")[0])
    with make_sim(PICK_PLACE, overrides={"behaviour.object": None, "behaviour.pick_positions": [start]}) as sim:
        before = sim.behaviour.check_goal(sim.world)
        assert not before.met and "never identified" in before.reason
        result = sim.run()
        assert result.outcome == "succeeded", result.reason
        assert result.reason == f"placed cube in {result.result['attempts']} attempt(s)"
        assert math.dist(sim.world.pose("cube")[0], PLACE) < TOLERANCE
        assert sim.behaviour.check_goal(sim.world).met
        sim.world.set_pose("cube", [0.6, 0.2, CUBE / 2], [0, 0, 0, 1])
        assert not sim.behaviour.check_goal(sim.world).met


@pytest.mark.slow
def test_patrol_visits_timeouts_trace_distance_and_stop_judged_by_the_world() -> None:
    """A far waypoint with a 2 s leg timeout and a near one, two laps. Each visit reached: the robot is within the
    tolerance of that waypoint in the world; each one missed: more than the timeout and less than one behaviour
    tick after it since the leg began; the trace has every visit in order; the outcome counts the misses; the
    distance reported is the path the world saw; and after the last leg the robot stands still."""
    waypoints, laps, timeout, rate = [[3.0, 1.8], [0.8, 0.0]], 2, 2.0, 20.0
    tolerance = 0.2  # patrol's documented default
    cfg = room({"waypoints": waypoints, "laps": laps, "waypoint_timeout": timeout, "rate_hz": rate}, box=False)
    with make_sim(cfg) as sim:
        patrol, world = sim.behaviour, sim.world
        visits: list[tuple[str, dict]] = []
        leg_began, path = 0.0, 0.0
        last = world.pose("robot")[0]
        while patrol.outcome is None and world.time < 40:
            sim.step(1)
            now = world.pose("robot")[0]
            path += math.dist(now[:2], last[:2])
            last = now
            new = [("waypoint_reached", v) for v in patrol.reached if ("waypoint_reached", v) not in visits]
            new += [("waypoint_missed", v) for v in patrol.missed if ("waypoint_missed", v) not in visits]
            assert len(new) <= 1
            for kind, v in new:
                leg = len(visits)
                assert (v["waypoint"], v["lap"]) == (leg % len(waypoints), leg // len(waypoints))
                assert abs(v["t"] - world.time) <= 1 / rate + 1e-6
                if kind == "waypoint_reached":
                    assert math.dist(now[:2], waypoints[v["waypoint"]]) <= tolerance + 0.02
                else:
                    assert timeout < v["t"] - leg_began <= timeout + 1 / rate + 1e-6
                leg_began = v["t"]
                visits.append((kind, v))
        assert len(visits) == len(waypoints) * laps
        kinds = [k for k, _ in visits]
        assert "waypoint_missed" in kinds and "waypoint_reached" in kinds
        trace = [(r["kind"], {k: r[k] for k in ("waypoint", "lap", "t")})
                 for r in sim.trace if r["kind"] in ("waypoint_reached", "waypoint_missed")]
        assert trace == visits
        missed = kinds.count("waypoint_missed")
        assert patrol.outcome.status == "failed" and f"{missed} of {len(visits)}" in patrol.outcome.reason
        result = patrol.result()
        assert (result["waypoints_reached"], result["waypoints_missed"]) == (len(visits) - missed, missed)
        assert result["distance_travelled"] == pytest.approx(path, rel=0.05, abs=0.02)
        assert result["visits"] == [v for k, v in visits if k == "waypoint_reached"]
        assert result["collision_events"] == [] and result["collisions"] == 0
        assert abs(result["sim_time"] - world.time) <= 1 / rate + 1e-6
        for _ in range(240):
            sim.step(1)
        assert math.hypot(*world.velocity("robot")[0][:2]) < 0.02


@pytest.mark.slow
def test_patrol_that_reaches_every_waypoint_succeeds_and_says_how_many() -> None:
    waypoints = [[0.7, 0.0], [0.7, 0.6]]
    with make_sim(room({"waypoints": waypoints, "waypoint_timeout": 20.0}, box=False)) as sim:
        result = sim.run(max_time=40)
        patrol, world = sim.behaviour, sim.world
        assert result.outcome == "succeeded", result.reason
        assert [(v["waypoint"], v["lap"]) for v in patrol.reached] == [(0, 0), (1, 0)] and not patrol.missed
        assert "all 2 waypoints" in result.reason
        assert math.dist(world.pose("robot")[0][:2], waypoints[-1]) <= 0.2 + 0.05


@pytest.mark.slow
def test_patrol_refuses_exactly_the_waypoints_inside_an_obstacle_grown_by_robot_radius() -> None:
    """Waypoints drawn round the 0.8 m box at (1.5, 0.5) on every side: refused, naming the waypoint's key, the box
    and its extent, exactly when the point lies in the box grown by robot_radius on each axis (computed here from
    the box's size and place); an unknown map body or contact sensor is refused at its key."""
    rng = np.random.default_rng(5)
    lo, hi = (1.1, 0.1), (1.9, 0.9)
    outcomes = set()
    for _ in range(16):
        radius = float(rng.choice([0.1, 0.3]))
        x, y = rng.uniform(lo[0] - 0.5, hi[0] + 0.5), rng.uniform(lo[1] - 0.5, hi[1] + 0.5)
        margins = [x - (lo[0] - radius), (hi[0] + radius) - x, y - (lo[1] - radius), (hi[1] + radius) - y]
        if min(abs(m) for m in margins) < 0.01:
            continue
        inside = all(m > 0 for m in margins)
        cfg = room({"waypoints": [[3.0, -0.8], [round(x, 3), round(y, 3)]], "robot_radius": radius})
        if inside:
            with pytest.raises(ConfigError) as err:
                make_sim(cfg)
            assert err.value.key.endswith("waypoints[1]")
            assert "'box'" in str(err.value) and f"x {lo[0]:.2f}..{hi[0]:.2f}, y {lo[1]:.2f}..{hi[1]:.2f}" in str(
                err.value)
        else:
            with make_sim(cfg) as sim:
                assert "box" in {b.name for b in sim.behaviour.map}
        outcomes.add(inside)
    assert outcomes == {True, False}
    with pytest.raises(ConfigError, match=r"unknown body 'shelf'.*wall_s") as err:
        make_sim(room({"waypoints": [[3.0, -0.8]], "map_bodies": ["box", "shelf"]}))
    assert err.value.key.endswith("map_bodies[1]")
    with pytest.raises(ConfigError, match="no sensor named 'bumper'") as err:
        make_sim(room({"waypoints": [[3.0, -0.8]], "contact_sensor": "bumper"}))
    assert err.value.key.endswith("contact_sensor")


@pytest.mark.slow
def test_patrol_collisions_from_the_drive_are_traced_one_per_new_map_contact() -> None:
    """Without a contact sensor the drive's contacts count: each new contact with a map body is one collision in
    the result and one ``collision`` record in the trace, at its time; a loose object never."""
    cfg = room({"waypoints": [[3.0, -0.8]]})
    del cfg["behaviour"]["contact_sensor"]
    with make_sim(cfg) as sim:
        patrol = sim.behaviour
        script = [("box",)] * 3 + [()] + [("box", "can")] * 2 + [("can", "wall_e")]
        expected = [("box", 0.0), ("box", 0.2), ("wall_e", 0.3)]
        for k, others in enumerate(script):
            patrol.count_collisions({"drive": SimpleNamespace(contacts=others)}, k * 0.05)
        assert [(c["body"], c["t"]) for c in patrol.result()["collision_events"]] == expected
        traced = [r["body"] for r in sim.trace if r["kind"] == "collision"]
        assert traced == [b for b, _ in expected]


@pytest.mark.slow
def test_sort_goal_names_each_object_out_of_its_bin_with_what_happened_to_it_in_the_world() -> None:
    """Before anything ran every cube is out of its bin and never seen; one removed from the world is said removed;
    one set down inside its colour's bin counts as in it, and the count of those missing follows."""
    with make_sim(ROOT / "configs" / "sort_robot.toml") as sim:
        world, sort = sim.world, sim.behaviour
        names = sorted(sort.goal_objects)
        check = sort.check_goal(world)
        assert not check.met and check.reason.startswith(f"{len(names)} of {len(names)} object(s) not in their bin")
        assert set(check.details["missed"]) == set(names)
        assert set(check.details["missed"].values()) == {"never seen by detector 'detector'"}
        gone, placed = names[0], names[-1]
        world.remove_body(gone)
        bin_lo, bin_hi = world.body_aabb(sort.bins[sort.goal_objects[placed]].body)
        centre = [(a + b) / 2 for a, b in zip(bin_lo, bin_hi, strict=True)]
        world.set_pose(placed, [centre[0], centre[1], bin_hi[2] + 0.03], [0, 0, 0, 1])
        for _ in range(240):
            world.step()
        cube = world.pose(placed)[0]
        assert all(lo <= c <= hi for c, lo, hi in zip(cube[:2], bin_lo[:2], bin_hi[:2], strict=True))
        check = sort.check_goal(world)
        assert check.details["in_bin"] == [placed]
        assert check.details["missed"][gone] == "removed from the world"
        assert set(check.details["missed"]) == set(names) - {placed}
        assert check.reason.startswith(f"{len(names) - 1} of {len(names)} object(s) not in their bin")


@pytest.mark.slow
@pytest.mark.parametrize("without_blue", [True, False])
def test_sort_says_how_many_it_sorted_and_what_it_left(without_blue: bool) -> None:
    """sort_robot.toml, and the same without its blue bin: the sort ends ``succeeded`` saying how many it sorted
    (the cubes the world has inside their colour's bin) in how many picks, and, without the blue bin, that it left the
    two blue cubes, whose colour has no bin; those are where they started."""
    import tomllib

    cfg = tomllib.loads((ROOT / "configs" / "sort_robot.toml").read_text(encoding="utf-8"))
    if without_blue:
        del cfg["behaviour"]["bins"]["blue"]
    cfg["world"]["max_time"] = 60.0
    sortable = ["red_0", "red_1"] + ([] if without_blue else ["blue_0", "blue_1"])
    with make_sim(cfg, base_dir=ROOT / "configs") as sim:
        world = sim.world
        blue_start = {n: world.pose(n)[0] for n in ("blue_0", "blue_1")}
        result = sim.run()
        in_bin = []
        for name in sortable:
            lo, hi = world.body_aabb(f"{name.split('_')[0]}_bin")
            if all(a <= c <= b for c, a, b in zip(world.pose(name)[0][:2], lo[:2], hi[:2], strict=True)):
                in_bin.append(name)
        picks = result.result["picks"]
        assert result.outcome == "succeeded", result.reason
        left = "; left 2 whose colour has no bin (blue)" if without_blue else ""
        assert result.reason == f"sorted {len(in_bin)} object(s) in {picks} pick(s){left}"
        assert in_bin == sortable and picks >= len(sortable)
        if without_blue:
            for name, start in blue_start.items():
                assert math.dist(world.pose(name)[0], start) < 0.01, f"{name} was moved"


@pytest.mark.slow
@pytest.mark.parametrize("yaw_deg", [-38.0, -17.0, 11.0, 29.0, 52.0])
def test_pick_place_grasps_a_turned_cube_across_two_faces(yaw_deg: float) -> None:
    """docs/arm.md: the gripper's yaw is the cube's yaw folded into +-45 degrees (a cube is 90-degree symmetric).
    A cube turned by yaws that are not their own mirror (never 0 or 45): when the fingers first close, the hand's
    closing axis, read from the world's hand frame, is square to the cube's faces (the cube's yaw, from the world,
    modulo 90 degrees) within 4 degrees."""
    from oracles import rotation

    with make_sim(PICK_PLACE) as sim:
        world = sim.world
        start = world.pose("cube")[0]
        half = math.radians(yaw_deg) / 2
        world.set_pose("cube", start, [0.0, 0.0, math.sin(half), math.cos(half)])
        panda = world.body("panda")
        hand = world.link(panda, "panda_hand")
        for _ in range(round(5 * world.physics_hz)):
            sim.step(1)
            if sim.readings["gripper"].action == "close":
                break
        assert sim.readings["gripper"].action == "close", "the fingers never closed"
        closing = rotation(world.pose(panda, hand)[1])[:, 1]  # the fingers close along the hand's y axis
        cube = rotation(world.pose("cube")[1])
        across = math.degrees(math.atan2(closing[1], closing[0])) - math.degrees(math.atan2(cube[1, 0], cube[0, 0]))
        off = (across + 45.0) % 90.0 - 45.0
        assert abs(off) < 4.0, f"the fingers close {off:.1f} degrees off the cube's faces"
