"""The collector's promises (docs/mobile.md) as properties, judged by the world and a plain reach test.

Objects of generated masses are placed at generated points of the robot's own frame (in the reach zone and round
it) with the robot at a generated place and heading that is no rotation's own inverse, under a generated reach
zone; the oracle is the zone written plainly in the robot's frame, the masses against ``max_mass``, and the world:
where each taken object is held (on the bin, apart from the others, carried along as the robot drives), where it was
taken, when, the trace, the constraints the world holds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.errors import ConfigError
from robokit.msgs.mobile import Collect, Twist
from robokit.testing import PLANE, make_sim

SIZE = 0.03
FOOTPRINT = (0.17, 0.17)  # half-extent of the diffbot seen from above, with room to spare: nothing placed inside


def scene(**collector: Any) -> dict[str, Any]:
    return {"bodies": {"plane": PLANE}, "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
            "actuators": {"drive": {"type": "diff_drive"}, "collector": {"type": "collector", **collector}}}


def to_world(pose: tuple[float, float, float], fx: float, fy: float) -> tuple[float, float]:
    x, y, yaw = pose
    return x + math.cos(yaw) * fx - math.sin(yaw) * fy, y + math.sin(yaw) * fx + math.cos(yaw) * fy


def matrix(w: Any, pose: tuple) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = np.asarray(w.matrix_from_quaternion(pose[1]), float).reshape(3, 3)
    m[:3, 3] = pose[0]
    return m


spots = st.tuples(st.floats(-0.45, 0.5), st.floats(-0.4, 0.4)).filter(
    lambda p: abs(p[0]) > FOOTPRINT[0] or abs(p[1]) > FOOTPRINT[1])
headings = st.one_of(st.floats(0.25, 2.9), st.floats(-2.9, -0.25))


@pytest.mark.slow
@settings(max_examples=8, deadline=None, derandomize=True)
@given(pose=st.tuples(st.floats(-1, 1), st.floats(-1, 1), headings),
       reach=st.tuples(st.floats(0.15, 0.25), st.floats(0.3, 0.45)), half_width=st.floats(0.08, 0.3),
       height=st.one_of(st.floats(0.02, 0.07), st.floats(0.07, 0.4)), max_mass=st.floats(0.2, 1.0),
       objects=st.lists(st.tuples(spots, st.sampled_from([0.5, 1.0, 1.5])), min_size=1, max_size=5))
def test_the_collector_takes_exactly_the_loose_objects_in_its_reach_zone(
        pose: tuple, reach: tuple, half_width: float, height: float, max_mass: float, objects: list) -> None:
    """Every object in the zone no heavier than ``max_mass`` is taken (one an update), no other; each is held on
    the bin apart from the others, keeps its place there while the robot drives, and the reading and the trace
    count them and say when and where the last was taken."""
    with make_sim(scene(armed=False, reach_x=list(reach), reach_half_width=half_width, reach_height=height,
                        max_mass=max_mass)) as sim:
        w, col = sim.world, sim.components["collector"]
        robot = w.body("robot")
        x, y, yaw = pose
        w.set_pose(robot, [x, y, 0.06], [0, 0, math.sin(yaw / 2), math.cos(yaw / 2)])
        sim.components["drive"].reset()
        want, placed = set(), {}
        for i, ((fx, fy), heavy) in enumerate(objects):
            if min(abs(fx - reach[0]), abs(fx - reach[1]), abs(abs(fy) - half_width)) < 0.005:
                continue  # on the zone's edge: either answer is a rounding
            if any(math.dist((fx, fy), p) < 2 * SIZE for p in placed.values()):
                continue  # not on top of another
            name = f"obj{i}"
            mass = heavy * max_mass  # 1.0: exactly the limit, still taken
            wx, wy = to_world(pose, fx, fy)
            w.add_primitive(name, "box", size=[SIZE] * 3, mass=mass, position=[wx, wy, SIZE / 2])
            placed[name] = (fx, fy)
            if reach[0] <= fx <= reach[1] and abs(fy) <= half_width and heavy <= 1.0:
                want.add(name)
        sim.step(2)
        assert col.read().count == 0 and col.read().last_at == -1.0 and col.read().last_position is None
        assert not col.read().armed
        before = len(sim.trace)
        start_time = w.time
        where = {n: w.pose(n)[0][:2] for n in placed}
        col.command(Collect(True))
        taken_at = {}
        for _ in range(len(placed) + 2):
            sim.step(1)
            state = col.read()
            for n in set(col.held) - set(taken_at):
                taken_at[n] = (w.time, state)
        state = col.read()
        assert state.armed and state.count == len(want)
        assert set(col.held) == want, (placed, want)
        counts = [r["count"] for r in sim.trace[before:] if r["kind"] == "collected"]
        assert counts == list(range(1, len(want) + 1))
        if want:
            last = col.held[-1]
            assert state.last_position == pytest.approx(where[last], abs=2e-3)
            assert start_time <= state.last_at == taken_at[last][1].last_at < taken_at[last][0]
        # held on the bin: above its level, apart, inside the robot's footprint; carried along as it drives
        bin_link = w.link(robot, "bin_link")
        bin_frame = matrix(w, w.pose(robot, bin_link))
        rel = {n: np.linalg.inv(bin_frame) @ matrix(w, w.pose(n)) for n in want}
        for n in want:
            lo, hi = w.aabb(n)
            assert bin_frame[2, 3] - 1e-3 <= lo[2] <= bin_frame[2, 3] + 0.01, n
            local = np.linalg.inv(matrix(w, w.pose(robot))) @ matrix(w, w.pose(n))
            assert abs(local[0, 3]) + SIZE / 2 < 0.15 and abs(local[1, 3]) + SIZE / 2 < 0.15
        for a in want:
            for b in want:
                if a < b:
                    assert np.linalg.norm(rel[a][:2, 3] - rel[b][:2, 3]) >= SIZE - 1e-3, (a, b)
        col.command(Collect(False))
        sim.components["drive"].command(Twist(0.2, 0.6))
        sim.step(240)
        bin_frame = matrix(w, w.pose(robot, bin_link))
        for n in want:
            now = np.linalg.inv(bin_frame) @ matrix(w, w.pose(n))
            assert np.allclose(now[:3, 3], rel[n][:3, 3], atol=3e-3), n
        assert col.read().count == len(want) and not col.read().armed


@pytest.mark.slow
def test_a_full_bin_holds_nine_objects_apart_on_its_floor() -> None:
    """Nine 4 cm cans in the zone, one taken an update: all nine held, each apart from every other, none below the
    bin's level or more than a centimetre above it, all inside the robot's footprint."""
    size = 0.04
    with make_sim(scene(armed=True, reach_x=[0.16, 0.5], reach_half_width=0.3)) as sim:
        w = sim.world
        for i in range(9):
            w.add_primitive(f"can{i}", "box", size=[size] * 3, mass=0.1,
                            position=[0.2 + 0.1 * (i % 3), 0.1 * (i // 3 - 1), size / 2])
        sim.step(12)
        assert sim.readings["collector"].count == 9
        robot = w.body("robot")
        base = matrix(w, w.pose(robot))
        level = w.pose(robot, w.link(robot, "bin_link"))[0][2]
        centres = []
        for i in range(9):
            lo, _ = w.aabb(f"can{i}")
            assert level - 1e-3 <= lo[2] <= level + 0.01, (i, lo[2], level)
            local = np.linalg.inv(base) @ matrix(w, w.pose(f"can{i}"))
            assert abs(local[0, 3]) + size / 2 < 0.16 and abs(local[1, 3]) + size / 2 < 0.15, i
            centres.append(local[:2, 3])
        for a in range(9):
            for b in range(a + 1, 9):
                assert np.linalg.norm(centres[a] - centres[b]) >= size - 1e-3, (a, b)


def test_a_held_object_is_never_taken_twice_even_in_reach() -> None:
    """A zone that also covers the bin itself: what is held there is not taken again."""
    with make_sim(scene(armed=True, reach_x=[-0.3, 0.4], reach_half_width=0.3, reach_height=1.0)) as sim:
        w = sim.world
        w.add_primitive("can", "box", size=[SIZE] * 3, mass=0.1, position=[0.25, 0.0, SIZE / 2])
        before = len(sim.trace)
        sim.step(10)
        assert sim.readings["collector"].count == 1
        assert [r["count"] for r in sim.trace[before:] if r["kind"] == "collected"] == [1]


def test_closing_the_collector_takes_its_holds_out_of_the_world() -> None:
    with make_sim(scene(armed=True)) as sim:
        w, client = sim.world, sim.world.client
        before = client.getNumConstraints()
        for i, fy in enumerate((-0.05, 0.05)):
            w.add_primitive(f"can{i}", "box", size=[SIZE] * 3, mass=0.1, position=[0.22, fy, SIZE / 2])
        sim.step(4)
        assert sim.readings["collector"].count == 2 and client.getNumConstraints() == before + 2
        sim.components["collector"].close()
        assert client.getNumConstraints() == before


@pytest.mark.parametrize(("key", "value"), [("robot", "rover"), ("bin_link", "basket")])
def test_an_unknown_robot_or_bin_is_refused_at_its_key(key: str, value: str) -> None:
    cfg = scene()
    cfg["actuators"]["collector"][key] = value
    with pytest.raises(ConfigError) as err:
        make_sim(cfg)
    assert err.value.key is not None and err.value.key.endswith(f"collector.{key}") and value in str(err.value)


def test_a_command_that_is_no_collect_is_refused_naming_it() -> None:
    with make_sim(scene()) as sim, pytest.raises(ValueError, match=r"Twist\(v=0\.1"):
        sim.components["collector"].command(Twist(0.1, 0.0))
