"""Arm tools and the IK arm, promises with independent expectations: suction never holds its own robot, yields above
max_force, reports its width by state; the gripper clamps widths, waits settle_time, ignores its own contacts; the
IK arm measures reach from its base, keeps min_duration, treats q and -q alike, interpolates the short way."""

from __future__ import annotations

import math

import numpy as np
import pytest
from robokit_plugins.ik_arm import _slerp

from robokit.msgs.arm import GripperCommand, MoveTo, down_quaternion
from robokit.testing import PLANE, make_sim

PANDA_READY = {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8, "panda_joint7": 0.785}


# ------------------------------------------------------------------ suction
def cup_scene(cube_mass: float, **suction: object) -> dict:
    return {"bodies": {"plane": PLANE,
                       "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": cube_mass,
                                "position": [0, 0, 0.025]},
                       "cup": {"shape": "cylinder", "radius": 0.02, "height": 0.02, "mass": 0,
                               "position": [0, 0, 0.0595]}},
            "actuators": {"cup": {"type": "suction", "body": "cup", **suction}}}


@pytest.mark.parametrize(("mass", "lifted"), [(0.5, True), (10.0, False)])
def test_suction_yields_to_a_load_above_max_force(mass: float, lifted: bool) -> None:
    """max_force 50 N: a 0.5 kg cube (4.9 N) comes along; a 10 kg one (98 N) tears off and stays down."""
    with make_sim(cup_scene(mass)) as sim:
        sim.components["cup"].command(GripperCommand("close"))
        sim.step(5)
        assert sim.readings["cup"].holding
        sim.world.set_pose("cup", (0.0, 0.0, 0.3))
        sim.step(240)
        z = sim.world.pose("cube")[0][2]
    assert (z > 0.2) is lifted, z


def test_suction_width_is_open_width_when_off_and_zero_when_on() -> None:
    with make_sim(cup_scene(0.1, open_width=0.07)) as sim:
        assert sim.readings["cup"].width == pytest.approx(0.07)
        sim.components["cup"].command(GripperCommand("close"))
        sim.step(1)
        assert sim.readings["cup"].width == 0.0
        sim.components["cup"].command(GripperCommand("open"))
        sim.step(1)
        assert sim.readings["cup"].width == pytest.approx(0.07)


def test_suction_never_holds_the_robot_it_is_mounted_on() -> None:
    """cup -> adapter -> holder (mounts); the cup's face dips 5 mm into the holder, which is not the cup's own
    parent (that pair's collisions are off). Turned on, the cup touches only its own robot: it holds nothing."""
    scene = {"bodies": {
        "holder": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 0, "position": [0, 0, 0.5]},
        "adapter": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1,
                    "mount": {"body": "holder", "link": "base", "position": [0.15, 0, 0]}},
        "cup": {"shape": "cylinder", "radius": 0.03, "height": 0.02, "mass": 0.05,
                "mount": {"body": "adapter", "link": "base", "position": [-0.05, 0, -0.105]}}},
        "actuators": {"cup": {"type": "suction", "body": "cup"}}}
    with make_sim(scene) as sim:
        touching = {c[2] for c in sim.world.client.getContactPoints(bodyA=sim.world.body("cup"))}
        sim.components["cup"].command(GripperCommand("close"))
        sim.step(20)
        touching |= {c[2] for c in sim.world.client.getContactPoints(bodyA=sim.world.body("cup"))}
        state = sim.readings["cup"]
        assert sim.world.body("holder") in touching  # the scene does what it says: the cup touches the holder
        assert not state.holding and state.held is None


# ------------------------------------------------------------------ gripper
def panda(self_collision: bool = False, **gripper: object) -> dict:
    return {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True,
                                 "self_collision": self_collision}},
            "actuators": {"gripper": {"type": "gripper", "body": "panda", **gripper}}}


def test_a_width_beyond_the_fingers_travel_is_clamped() -> None:
    with make_sim(panda()) as sim:
        sim.components["gripper"].command(GripperCommand("width", width=0.5))
        sim.step(2)
        assert sim.readings["gripper"].target_width == pytest.approx(0.08)  # two fingers of 0.04 m
        sim.components["gripper"].command(GripperCommand("width", width=-0.2))
        sim.step(2)
        assert sim.readings["gripper"].target_width == 0.0


@pytest.mark.parametrize("self_collision", [False, True])
def test_settled_only_after_settle_time_of_stillness_and_no_self_contacts(self_collision: bool) -> None:
    """Closing on nothing: 'settled' comes settle_time (0.04 s) after the width stopped changing, not before; the
    fingers touching each other (with self_collision they do) are not finger contacts, and nothing is held."""
    with make_sim(panda(self_collision, settle_time=0.04)) as sim:
        g = sim.components["gripper"]
        g.command(GripperCommand("close"))
        dt = sim.world.time_step
        last_move, first_settled, last_width = 0.0, None, sim.readings["gripper"].width
        for _ in range(480):
            sim.step(1)
            state = sim.readings["gripper"]
            if abs(state.width - last_width) / dt > 0.01:  # settle_speed, m/s
                last_move = sim.world.time
            last_width = state.width
            if state.settled and first_settled is None:
                first_settled = sim.world.time
        assert first_settled is not None
        assert first_settled - last_move >= 0.04 - dt - 1e-9
        assert state.finger_contacts == 0 and not state.holding and state.width < 0.004


# ------------------------------------------------------------------ ik_arm
def arm(base: list[float] | None = None, **cfg: object) -> dict:
    return {"bodies": {"plane": PLANE},
            "robots": {"robot": {"urdf": "franka_panda/panda.urdf", "position": base or [0, 0, 0], "fixed_base": True}},
            "actuators": {"arm": {"type": "ik_arm", "body": "robot", "ee_link": "panda_grasptarget",
                                  "ready_pose": PANDA_READY, **cfg}}}


def test_reach_is_measured_from_the_arms_base() -> None:
    """Base at x = 1 m, reach 0.85 m: a target 0.55 m from the base (1.5 m from the world origin) is planned; one
    0.9 m from the base is refused."""
    with make_sim(arm([1.0, 0.0, 0.0], reach=0.85)) as sim:
        a = sim.components["arm"]
        a.command(MoveTo((1.5, 0.0, 0.3)))
        assert a.status == "moving", a.reason
        a.command(MoveTo((1.9, 0.0, 0.0)))
        assert a.status == "failed" and "0.900 m from the base" in a.reason


def test_a_tiny_move_still_takes_min_duration() -> None:
    with make_sim(arm(min_duration=0.2)) as sim:
        sim.step(10)
        here = sim.readings["arm"].position
        sim.components["arm"].command(MoveTo((here[0], here[1], here[2] + 0.001)))
        sim.step(1)
        state = sim.readings["arm"]
        assert state.path_end is not None and state.path_end - sim.world.time >= 0.2 - 2 / 240


def test_a_target_given_as_minus_q_is_the_same_orientation() -> None:
    """q and -q are one rotation: a move to (p, -q) is reached with an orientation error near 0."""
    q = down_quaternion(0.3)
    with make_sim(arm()) as sim:
        sim.components["arm"].command(MoveTo((0.5, 0.1, 0.3), orientation=tuple(-v for v in q)))
        for _ in range(20):
            sim.step(24)
            if sim.readings["arm"].status != "moving":
                break
        state = sim.readings["arm"]
        assert state.status == "reached", state.reason
        assert state.orientation_error < 0.05


def test_slerp_takes_the_short_way_round() -> None:
    """From identity to -(a 90 deg turn about z): the same rotation as +(90 deg), so halfway is 45 deg about z."""
    a = (0.0, 0.0, 0.0, 1.0)
    s, c = math.sin(math.pi / 4), math.cos(math.pi / 4)
    half = _slerp(a, (0.0, 0.0, -s, -c), 0.5)
    want = (0.0, 0.0, math.sin(math.pi / 8), math.cos(math.pi / 8))
    assert half == pytest.approx(want, abs=1e-9) or half == pytest.approx(tuple(-v for v in want), abs=1e-9)


def test_an_object_touching_one_finger_only_is_not_held() -> None:
    """A fixed 1 cm block 2 cm off the grasp centre towards the left finger: closing, the left finger meets it
    (the gear stops the right one too, 2 cm short of it): one finger touches, nothing is held."""
    with make_sim(panda()) as sim:
        w = sim.world
        left = np.array(w.pose("panda", w.link("panda", "panda_leftfinger"))[0])
        right = np.array(w.pose("panda", w.link("panda", "panda_rightfinger"))[0])
        centre = np.array(w.pose("panda", w.link("panda", "panda_grasptarget"))[0])
        towards_left = (left - right) / np.linalg.norm(left - right)
        w.add_primitive("block", "box", size=(0.01, 0.01, 0.01), mass=0.0,
                        position=tuple(centre + 0.02 * towards_left))
        sim.components["gripper"].command(GripperCommand("close"))
        sim.step(240)
        state = sim.readings["gripper"]
    assert state.finger_contacts > 0  # it does touch
    assert state.width > 0.02 and not state.holding and state.held is None


def test_reached_needs_both_tolerances_and_failure_waits_settle_timeout() -> None:
    """position_tolerance 1e-7 m (tighter than any real tracking, orientation default 0.05 rad): the move is never
    'reached' although its orientation is well within tolerance, and it fails only settle_timeout (0.3 s) after
    the path ended, naming the miss."""
    with make_sim(arm(position_tolerance=1e-7, settle_timeout=0.3)) as sim:
        sim.components["arm"].command(MoveTo((0.5, 0.2, 0.2)))
        seen = set()
        for _ in range(720):
            sim.step(1)
            state = sim.readings["arm"]
            seen.add(state.status)
            if state.status != "moving":
                break
        assert state.status == "failed" and "reached" not in seen
        assert state.orientation_error < 0.05 and state.position_error < 0.001  # it is there, to within 1 mm
        assert state.path_end is not None and sim.world.time >= state.path_end + 0.3 - 1e-9
        assert "did not reach the target" in state.reason


def test_configured_joint_limits_are_never_exceeded() -> None:
    """panda_joint1 limited to [-0.1, 0.1] rad: a target 37 deg to the left (atan2(0.3, 0.4)) needs more; the
    arm either refuses it or gets there within the limit, never beyond."""
    with make_sim(arm(limits={"panda_joint1": [-0.1, 0.1]})) as sim:
        sim.components["arm"].command(MoveTo((0.4, 0.3, 0.3)))
        for _ in range(480):
            sim.step(1)
            state = sim.readings["arm"]
            assert state.joint_positions["panda_joint1"] <= 0.1 + 2e-3
            if state.status != "moving":
                break
