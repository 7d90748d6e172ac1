"""The gripper against the world, as properties over generated commands and hand orientations.

docs/arm.md and the plugin's docstring promise: a ``width`` command drives the fingertips to that distance (clamped
to 0 .. the open width), ``open``/``close`` to the ends; the fingers stay symmetric; ``settled`` means the width has
stopped changing; ``holding`` means both fingers touch the same body with the width above ``empty_width``, and
``held`` names it; a protective stop freezes the fingers where they are. The oracle is the world: the fingertip
distance is measured along the hand's own closing axis (the hand's rotation matrix written here from its
quaternion, at random arm joint angles: random orientations, never only the identity), finger motion from the link
velocities, touching from the world's unfiltered contact points.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, assume, example, given, settings
from hypothesis import strategies as st
from oracles import rotation

from robokit.errors import ConfigError
from robokit.msgs.arm import GripperCommand
from robokit.testing import make_sim

NO_SHRINK = [Phase.explicit, Phase.generate]  # an example is a simulation: a failing one is reported as drawn

OPEN = 0.08  # the Panda's two finger joints open to 0.04 m each (panda.urdf)
SCENE: dict[str, Any] = {
    "world": {"gravity": [0, 0, 0]},  # the arm stays where it is put: the hand's pose is the generated one
    "bodies": {"cube": {"shape": "box", "size": [0.04, 0.04, 0.04], "mass": 0.0, "position": [3, 3, 0.5]}},
    "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {"gripper": {"type": "gripper", "body": "panda"}},
}
ARM = [f"panda_joint{i}" for i in range(1, 8)]


@pytest.fixture(scope="module")
def sim() -> Iterator[Any]:
    with make_sim(SCENE) as s:
        yield s


def link(sim: Any, name: str) -> int:
    w = sim.world
    return next(j.index for j in w.joints("panda") if j.child_link == name)


def fingertips(sim: Any) -> tuple[float, float, float]:
    """Measured in the world: the fingertip distance along the hand's closing (y) axis, how far the fingers'
    midpoint is off the hand's centre line along it, and the fingers' speed apart (m/s)."""
    w = sim.world
    hand_pos, hand_orn = w.pose("panda", link(sim, "panda_hand"))
    axis = rotation(hand_orn)[:, 1]
    left = np.array(w.pose("panda", link(sim, "panda_leftfinger"))[0])
    right = np.array(w.pose("panda", link(sim, "panda_rightfinger"))[0])
    v_left = np.array(w.link_velocity("panda", link(sim, "panda_leftfinger"))[0])
    v_right = np.array(w.link_velocity("panda", link(sim, "panda_rightfinger"))[0])
    middle = (left + right) / 2 - np.array(hand_pos)
    return float((left - right) @ axis), float(middle @ axis), float((v_left - v_right) @ axis)


def put_hand(sim: Any, angles: list[float]) -> None:
    w = sim.world
    body = w.body("panda")
    for name, q in zip(ARM, angles, strict=True):
        w.reset_joint(body, w.joint("panda", name).index, q, 0.0)


def settle(sim: Any, ticks: int = 400) -> int:
    sim.step(1)
    for n in range(ticks):
        if sim.readings["gripper"].settled:
            return n
        sim.step(1)
    raise AssertionError("the gripper never settled")


arm_angles = st.lists(st.floats(-1.2, 1.2), min_size=7, max_size=7)


@settings(max_examples=6, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(angles=arm_angles,
       cmd=st.one_of(st.tuples(st.just("width"), st.floats(-0.05, 0.15)), st.tuples(st.sampled_from(["open", "close"]),
                                                                                     st.just(None))),
       force=st.one_of(st.none(), st.floats(5.0, 60.0)))
def test_the_fingertips_go_to_the_commanded_width_in_the_world(sim: Any, angles: list[float], cmd: tuple,
                                                               force: float | None) -> None:
    sim.world.set_pose("cube", (3, 3, 0.5))  # out of reach: the fingers close on nothing
    put_hand(sim, angles)
    action, width = cmd
    want = {"open": OPEN, "close": 0.0}.get(action, min(max(width or 0.0, 0.0), OPEN))
    g = sim.components["gripper"]
    g.command(GripperCommand(action, width=width, force=force))
    settle(sim)
    r = sim.readings["gripper"]
    measured, off_centre, speed = fingertips(sim)
    assert r.target_width == pytest.approx(want, abs=1e-12) and r.action == action
    assert measured == pytest.approx(want, abs=1.5e-3), "the fingertips are where the command put them"
    assert r.width == pytest.approx(measured, abs=5e-4), "the reading is the world's fingertip distance"
    assert abs(off_centre) < 1e-3, "the fingers stay symmetric about the hand"
    assert abs(speed) <= 0.011, "settled: the fingers no longer move apart or together"
    assert not r.holding and r.held is None and r.finger_contacts == 0 and not r.stopped


@settings(max_examples=8, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(angles=arm_angles, size=st.floats(0.015, 0.05), yaw=st.floats(-0.3, 0.3), off=st.floats(-0.025, 0.025),
       beside=st.booleans())
def test_holding_is_both_fingers_touching_one_body_in_the_world(sim: Any, angles: list[float], size: float,
                                                                 yaw: float, off: float, beside: bool) -> None:
    """A static cube of a generated size put between the fingertips, off the centre line by a generated distance
    along the closing axis (the coupled fingers then stop when the nearer one touches it: only one finger may
    touch), or beside the hand; then a close: holding and held agree with the world's contacts of each finger,
    and the width with where the cube is."""
    w = sim.world
    g = sim.components["gripper"]
    g.command(GripperCommand("open"))
    settle(sim)
    put_hand(sim, angles)
    w.set_pose("cube", (3, 3, 0.5))
    sim.step(1)
    target_pos, target_orn = w.pose("panda", link(sim, "panda_grasptarget"))
    rot = rotation(target_orn)
    spin = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    # the cube at the grasp target moved ``off`` along the closing (y) axis, turned a little about the approach
    # axis; or 0.3 m beside the hand
    where = np.array(target_pos) + off * rot[:, 1] + (0.3 if beside else 0.0) * rot[:, 0]
    m = rot @ spin
    qw = np.sqrt(max(1e-12, 1 + np.trace(m))) / 2
    quat = ((m[2, 1] - m[1, 2]) / (4 * qw), (m[0, 2] - m[2, 0]) / (4 * qw), (m[1, 0] - m[0, 1]) / (4 * qw), qw)
    w.remove_body("cube")
    w.add_primitive("cube", "box", size=[size, size, size], mass=0.0, position=list(where), orientation=quat)
    fingers = {link(sim, n) for n in ("panda_leftfinger", "panda_rightfinger")}
    near = w.client.getClosestPoints(w.body("cube"), w.body("panda"), 0.01)
    assume(all(pt[4] in fingers for pt in near))  # only the fingers can meet the cube (not a folded arm's links)
    g.command(GripperCommand("close"))
    settle(sim)
    r = sim.readings["gripper"]
    cube = w.body("cube")
    touching = [any(c.other == cube for c in w.contacts(w.body("panda"), link=link(sim, name)))
                for name in ("panda_leftfinger", "panda_rightfinger")]
    measured = fingertips(sim)[0]
    half = size / 2 * (np.cos(yaw) + np.sin(abs(yaw)))  # the cube's half extent along the closing axis
    assert r.width == pytest.approx(measured, abs=5e-4)
    assert r.holding == (all(touching) and measured > 0.004), f"holding {r.holding}, touching {touching}"
    assert r.held == ("cube" if r.holding else None)
    assert r.finger_contacts == sum(len([c for c in w.contacts(w.body("panda"), link=link(sim, name))
                                         if c.other != w.body("panda")])
                                    for name in ("panda_leftfinger", "panda_rightfinger"))
    if beside:
        assert not any(touching) and not r.holding and measured < 0.004, "closed on nothing"
    else:
        assert any(touching), "a closing finger meets the cube between them"
        # the coupled fingers stop when the nearer one meets the cube: never closer than 2 (|off| + size / 2) (a
        # square reaches at least half its side in every direction), never wider than the corners allow plus the
        # finger hulls, which widen towards the hand
        assert 2 * (abs(off) + size / 2) - 3e-3 <= measured <= 2 * (abs(off) + half) + 0.015
        if abs(off) < 1e-3:
            assert all(touching) and r.holding, "a centred cube is held once the fingers close"


@settings(max_examples=5, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(start=st.floats(0.0, OPEN), goal=st.one_of(st.floats(0.0, OPEN), st.sampled_from(["open", "close"])),
       ticks=st.integers(3, 25))
@example(start=0.07, goal="close", ticks=8)
@example(start=0.01, goal="open", ticks=8)
def test_a_protective_stop_freezes_the_fingers_where_they_are(sim: Any, start: float, goal: float | str,
                                                              ticks: int) -> None:
    """Stopped mid-travel on nothing (towards a width, or opening, or closing): the fingers stay at the width they
    had, in the world, the reading says stopped until the next command, and the run's trace records the stop."""
    sim.world.set_pose("cube", (3, 3, 0.5))
    g = sim.components["gripper"]
    g.command(GripperCommand("width", width=start))
    settle(sim)
    g.command(GripperCommand(goal, width=None) if isinstance(goal, str) else GripperCommand("width", width=goal))
    sim.step(ticks)
    at_stop = fingertips(sim)[0]
    before = len(sim.trace)
    g.protective_stop("a test")
    assert [(r["kind"], r["actuator"], r["reason"]) for r in sim.trace[before:]] == [
        ("protective_stop", "gripper", "a test")]
    sim.step(60)
    r = sim.readings["gripper"]
    assert r.stopped and r.action == "width"
    assert fingertips(sim)[0] == pytest.approx(at_stop, abs=2.5e-3), "the fingers held the width of the stop"
    assert r.target_width == pytest.approx(at_stop, abs=2.5e-3)
    g.command(GripperCommand("open"))
    sim.step(1)
    assert not sim.readings["gripper"].stopped


@settings(max_examples=3, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(size=st.floats(0.02, 0.045), ticks=st.integers(0, 30))
def test_a_protective_stop_keeps_a_grip_on_what_the_fingers_hold(sim: Any, size: float, ticks: int) -> None:
    """Closed on a cube and holding it, a protective stop keeps the grip (dropping it is not safe): the command stays
    ``close``, the fingers keep squeezing the cube, the reading still holds it."""
    w = sim.world
    g = sim.components["gripper"]
    g.command(GripperCommand("open"))
    settle(sim)
    put_hand(sim, [0.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785])
    w.set_pose("cube", (3, 3, 0.5))
    sim.step(1)
    target_pos, target_orn = w.pose("panda", link(sim, "panda_grasptarget"))
    w.remove_body("cube")
    w.add_primitive("cube", "box", size=[size] * 3, mass=0.0, position=list(target_pos), orientation=target_orn)
    g.command(GripperCommand("close"))
    settle(sim)
    sim.step(ticks)
    assert sim.readings["gripper"].holding
    g.protective_stop("a test")
    sim.step(60)
    r = sim.readings["gripper"]
    cube = w.body("cube")
    touching = [any(c.other == cube for c in w.contacts(w.body("panda"), link=link(sim, name)))
                for name in ("panda_leftfinger", "panda_rightfinger")]
    assert r.stopped and r.action == "close" and r.target_width == 0.0
    assert all(touching) and r.holding and r.held == "cube"
    assert fingertips(sim)[0] == pytest.approx(size, abs=3e-3), "squeezing the cube, not closed past it"
    w.set_pose("cube", (3, 3, 0.5))
    g.command(GripperCommand("open"))
    settle(sim)


# ------------------------------------------------------------------------ other grippers, set up by config
KUKA_SDF = {"sdf": "kuka_iiwa/kuka_with_gripper2.sdf", "position": [0.3, -0.2, 0.0], "fixed_base": True}
TWO_REVOLUTE = {  # the KUKA's SDF gripper: two revolute fingers and two fingertip hinges held straight
    "type": "gripper", "body": "kuka", "finger_joints": ["base_left_finger_joint", "base_right_finger_joint"],
    "open_positions": [-0.22, 0.22], "closed_positions": [0.05, -0.05], "open_width": 0.084,
    "hold_joints": {"left_base_tip_joint": 0.1, "right_base_tip_joint": -0.1},  # not 0: a motor's default target
}
MIMIC = {**TWO_REVOLUTE, "finger_joints": ["base_left_finger_joint"], "open_positions": [-0.22],
         "closed_positions": [0.05], "mimic": {"base_right_finger_joint": -1.0},
         "finger_links": [["left_finger", "left_finger_base", "left_finger_tip"],
                          ["right_finger", "right_finger_base", "right_finger_tip"]]}


@pytest.fixture(scope="module", params=["two_revolute", "mimic"])
def kuka_gripper(request: pytest.FixtureRequest) -> Iterator[tuple[Any, dict[str, Any]]]:
    gripper = TWO_REVOLUTE if request.param == "two_revolute" else MIMIC
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {"kuka": KUKA_SDF}, "actuators": {"gripper": gripper}}
    with make_sim(config) as s:
        yield s, gripper


@settings(max_examples=4, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.floats(-0.02, 0.12), force=st.one_of(st.none(), st.floats(5.0, 40.0)))
def test_configured_fingers_go_to_the_joint_positions_linear_in_the_width(kuka_gripper: tuple, width: float,
                                                                          force: float | None) -> None:
    """A width is linear in each finger joint's travel from closed to open (the plugin's docstring): the world's
    joint positions are the plain interpolation, a mimic follower is its ratio times the driven joint, the
    held hinges stay where they are held, and the reading's width is read back from the world's joints."""
    sim, cfg = kuka_gripper
    w = sim.world
    kuka = w.body("kuka")
    sim.components["gripper"].command(GripperCommand("width", width=width, force=force))
    settle(sim, 600)
    sim.step(30)
    frac = min(max(width, 0.0), cfg["open_width"]) / cfg["open_width"]
    measured = []
    for name, o, c in zip(cfg["finger_joints"], cfg["open_positions"], cfg["closed_positions"], strict=True):
        q = w.joint_states(kuka, [w.joint("kuka", name).index])[0][0]
        assert q == pytest.approx(c + frac * (o - c), abs=6e-3), name
        measured.append((q - c) / (o - c))
    for follower, ratio in cfg.get("mimic", {}).items():
        q_lead = w.joint_states(kuka, [w.joint("kuka", cfg["finger_joints"][0]).index])[0][0]
        q = w.joint_states(kuka, [w.joint("kuka", follower).index])[0][0]
        assert q == pytest.approx(ratio * q_lead, abs=0.01), follower
    for held, q_held in cfg["hold_joints"].items():
        assert w.joint_states(kuka, [w.joint("kuka", held).index])[0][0] == pytest.approx(q_held, abs=0.02), held
    r = sim.readings["gripper"]
    assert r.width == pytest.approx(cfg["open_width"] * sum(measured) / len(measured), abs=1e-6)
    assert r.target_width == pytest.approx(frac * cfg["open_width"], abs=1e-12)


# ------------------------------------------------------------------------ set-up mistakes, and closing
PANDA = {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}
FINGERS = ["panda_finger_joint1", "panda_finger_joint2"]
MISTAKES = [  # (robot, gripper settings, the key named, the message, or its start up to the list that follows)
    (PANDA, {"finger_joints": ["panda_finger_joint1", "panda_hand_joint"]}, "finger_joints[1]",
     "finger joint 'panda_hand_joint' must be prismatic or revolute, got fixed"),
    (PANDA, {"finger_joints": ["panda_finger_joint1", "panda_finger_joint3"]}, "finger_joints[1]",
     "unknown joint 'panda_finger_joint3'"),
    (PANDA, {"open_positions": [0.04, 0.0], "closed_positions": [0.0, 0.0]}, "open_positions",
     "each finger joint's open and closed positions must differ"),
    (KUKA_SDF, {k: v for k, v in TWO_REVOLUTE.items() if k not in ("open_width", "type")}, "open_width",
     "give 'open_width' (fingertip distance when open, metres) for revolute or single-joint fingers"),
    (PANDA, {"finger_joints": ["panda_finger_joint1"], "finger_links": [["panda_leftfinger"], ["panda_rightfinger"]]},
     "open_width", "give 'open_width' (fingertip distance when open, metres) for revolute or single-joint fingers"),
    (PANDA, {"finger_joints": ["panda_finger_joint1"], "open_width": 0.08, "mimic": {"panda_finger_jont2": 1.0},
             "finger_links": [["panda_leftfinger"], ["panda_rightfinger"]]}, "mimic.panda_finger_jont2",
     "unknown joint 'panda_finger_jont2'"),
    (PANDA, {"hold_joints": {"panda_joint9": 0.0}}, "hold_joints.panda_joint9", "unknown joint 'panda_joint9'"),
    (PANDA, {"stop_on": "arm"}, "stop_on", "'arm' is not a contact sensor; components: "),
    (PANDA, {"finger_links": [["panda_leftfinger"], ["panda_hand", "panda_rightfingr"]]}, "finger_links[1]",
     "unknown link 'panda_rightfingr'"),
]


@pytest.mark.parametrize(("robot", "settings_", "key", "message"), MISTAKES,
                         ids=[m[2] + "-" + m[3][:12] for m in MISTAKES])
def test_a_gripper_set_up_wrongly_names_the_key_and_the_fix(robot: dict, settings_: dict, key: str,
                                                            message: str) -> None:
    body = "kuka" if robot is KUKA_SDF else "panda"
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {body: robot},
              "actuators": {"arm": {"type": "joint_control", "body": body},
                            "gripper": {"type": "gripper", "body": body, **settings_}}}
    with pytest.raises(ConfigError) as err:
        with make_sim(config):
            pass
    assert err.value.key == f"actuators.gripper.{key}"
    assert err.value.message.startswith(message), err.value.message


@pytest.mark.parametrize("closed", [0.0, 0.01])
def test_the_default_open_width_is_the_fingers_travel_and_close_lets_the_fingers_go(closed: float) -> None:
    """Prismatic fingers' open width is the sum of their travels from closed to open (the width is linear in the
    travel: a width of 0 is the closed positions); closing the gripper removes the gear that coupled its fingers
    (a closed gripper leaves no constraint behind in the world)."""
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {"panda": PANDA},
              "actuators": {"gripper": {"type": "gripper", "body": "panda", "closed_positions": [closed, closed]}}}
    with make_sim(config) as s:
        w = s.world
        upper = [w.joint("panda", n).upper for n in FINGERS]
        assert s.readings["gripper"].width == pytest.approx(sum(u - closed for u in upper), abs=1e-9)
        gears = w.client.getNumConstraints()
        s.components["gripper"].close()
        assert w.client.getNumConstraints() == gears - 1
        s.components["gripper"].close()  # twice is harmless
        assert w.client.getNumConstraints() == gears - 1


# ------------------------------------------------------------------------ speed, a fresh build, stop_on, reset
@pytest.mark.slow  # about 0.9 s
@settings(max_examples=4, deadline=None, derandomize=True, phases=NO_SHRINK)
@given(speed=st.floats(0.03, 0.15), closed=st.sampled_from([0.0, 0.01]), opening=st.booleans())
def test_the_fingers_move_at_the_configured_finger_speed(speed: float, closed: float, opening: bool) -> None:
    """``finger_speed`` is each finger's speed, m/s: the fingertip distance measured in the world changes at twice
    it (two fingers) while the fingers travel, and no faster; the whole travel takes its length over that rate."""
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {"panda": PANDA},
              "actuators": {"gripper": {"type": "gripper", "body": "panda", "finger_speed": speed,
                                        "closed_positions": [closed, closed], "start_open": not opening}}}
    with make_sim(config) as s:
        travel = 2 * (0.04 - closed)
        s.step(5)
        s.components["gripper"].command(GripperCommand("open" if opening else "close"))
        rates, start = [], fingertips(s)[0]
        for _ in range(round(1.5 * travel / (2 * speed) * 240) + 60):
            s.step(1)
            rates.append(abs(fingertips(s)[2]))
        assert max(rates) <= 2 * speed * 1.05, f"peak {max(rates):.4f} m/s, promised {2 * speed:.4f}"
        middle = rates[10:round(travel / (2 * speed) * 240) - 10]
        assert middle and min(middle) >= 2 * speed * 0.9, "the fingers travel at the configured speed"
        assert abs(fingertips(s)[0] - start) == pytest.approx(travel, abs=2e-3)


@pytest.mark.parametrize("start_open", [True, False])
def test_a_fresh_gripper_reads_its_start_state(start_open: bool) -> None:
    """Built and left alone: open (or closed with ``start_open = false``), at rest, so ``settled`` once
    ``settle_time`` has passed; its action is ``open`` either way and it holds nothing."""
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {"panda": PANDA},
              "actuators": {"gripper": {"type": "gripper", "body": "panda", "start_open": start_open}}}
    with make_sim(config) as s:
        want = OPEN if start_open else 0.0
        s.step(round(0.05 * 240))
        r = s.readings["gripper"]
        assert (r.action, r.target_width, r.stopped, r.holding, r.held) == ("open", want, False, False, None)
        assert r.settled and r.width == pytest.approx(want, abs=1e-4)
        assert fingertips(s)[0] == pytest.approx(want, abs=1.5e-3)


TOUCHY = {"world": {"gravity": [0, 0, 0]}, "robots": {"panda": PANDA},
          "bodies": {"cube": {"shape": "box", "size": [0.03, 0.03, 0.03], "mass": 0.0, "position": [3, 3, 0.5]}},
          "sensors": {"touch": {"type": "contact", "body": "panda", "other": "cube"}},
          "actuators": {"gripper": {"type": "gripper", "body": "panda", "stop_on": "touch", "stop_force": 0.0}}}


def put_cube_between_fingers(sim: Any) -> None:
    w = sim.world
    put_hand(sim, [0.0, 0.3, 0.0, -1.8, 0.0, 2.1, 0.785])
    sim.step(1)
    pos, orn = w.pose("panda", link(sim, "panda_grasptarget"))
    w.set_pose("cube", pos, orn)


def test_stop_on_freezes_the_fingers_at_the_first_contact_for_good() -> None:
    """``stop_on``: the first contact above ``stop_force`` stops the fingers where they are, says so in the
    reading and the trace (naming what was touched, the force and the sensor), and later commands are ignored."""
    with make_sim(TOUCHY) as s:
        g = s.components["gripper"]
        put_cube_between_fingers(s)
        g.command(GripperCommand("close"))
        for _ in range(240):
            s.step(1)
            if [r for r in s.trace if r["kind"] == "protective_stop"]:
                break
        stops = [r for r in s.trace if r["kind"] == "protective_stop"]
        assert len(stops) == 1 and stops[0]["actuator"] == "gripper"
        assert stops[0]["reason"].startswith("contact with cube (") and stops[0]["reason"].endswith(" N) (touch)")
        assert s.readings["touch"].in_contact
        at_stop = fingertips(s)[0]
        g.command(GripperCommand("open"))
        s.step(120)
        r = s.readings["gripper"]
        assert r.stopped and fingertips(s)[0] == pytest.approx(at_stop, abs=3e-3), "the open was ignored"
        assert len([x for x in s.trace if x["kind"] == "protective_stop"]) == 1


@pytest.mark.parametrize("force", [0.0, 1e6])
def test_stop_on_does_not_stop_below_its_force(force: float) -> None:
    """No contact, or contacts no harder than ``stop_force``: the fingers close as commanded."""
    config = {**TOUCHY, "actuators": {"gripper": {**TOUCHY["actuators"]["gripper"], "stop_force": force}}}
    with make_sim(config) as s:
        if force:
            put_cube_between_fingers(s)
        s.components["gripper"].command(GripperCommand("close"))
        s.step(120)
        r = s.readings["gripper"]
        assert not r.stopped and not [x for x in s.trace if x["kind"] == "protective_stop"]
        assert fingertips(s)[0] == pytest.approx(0.03 if force else 0.0, abs=3e-3)


def gripper_state(sim: Any) -> tuple:
    """The finger joints' positions and velocities in the world and every field of the reading."""
    w = sim.world
    panda = w.body("panda")
    joints = [j.index for j in w.joints(panda) if j.movable]
    return tuple(w.joint_states(panda, joints)), sim.readings["gripper"]


@pytest.mark.slow  # about 0.6 s
@settings(max_examples=4, deadline=None, derandomize=True, phases=NO_SHRINK)
@given(history=st.lists(st.tuples(st.sampled_from(["open", "close", "width", "stop", "cube"]), st.floats(0, 0.08),
                                  st.integers(1, 40)), min_size=1, max_size=5))
@example(history=[("close", 0.0, 10), ("stop", 0.0, 5)])
@example(history=[("cube", 0.0, 1), ("close", 0.0, 40)])  # stop_on stops the fingers for the rest of the run
def test_a_reset_gripper_is_a_fresh_one(history: list) -> None:
    """``reset()`` (between robokit.gym episodes, after the world's snapshot is restored) gives the start state of a
    fresh build, whatever came before (commands, protective stops, a ``stop_on`` stop): the same reading field for
    field, the same joint states, and the same next ticks with no command and then a close, bit for bit."""
    with make_sim(TOUCHY) as used, make_sim(TOUCHY) as fresh:
        snap = used.world.snapshot()
        g = used.components["gripper"]
        for what, width, ticks in history:
            if what == "stop":
                g.protective_stop("a test")
            elif what == "cube":
                put_cube_between_fingers(used)
            else:
                g.command(GripperCommand(what, width=width if what == "width" else None))
            used.step(ticks)
        used.world.restore(snap)
        for comp in used.components.values():
            if hasattr(comp, "reset"):  # as robokit.gym resets them
                comp.reset(None)
        for sim in (used, fresh):
            sim.step(1)
        assert gripper_state(used) == gripper_state(fresh)
        for sim in (used, fresh):
            sim.step(30)
        assert gripper_state(used) == gripper_state(fresh)
        for sim in (used, fresh):
            sim.components["gripper"].command(GripperCommand("close"))
            sim.step(30)
        assert gripper_state(used) == gripper_state(fresh)


def test_a_fingers_links_are_the_links_its_joint_moves() -> None:
    """Without ``finger_links``, a finger is its joint's child link and every link below it: judged by the world,
    the links whose pose changes when that finger joint alone turns (the KUKA's fingers carry their tips)."""
    config = {"world": {"gravity": [0, 0, 0]}, "robots": {"kuka": KUKA_SDF},
              "actuators": {"gripper": {k: v for k, v in TWO_REVOLUTE.items() if k != "hold_joints"}}}
    with make_sim(config) as s:
        w = s.world
        kuka = w.body("kuka")
        links = [j.index for j in w.joints(kuka)]
        for finger, name in zip(s.components["gripper"].links, TWO_REVOLUTE["finger_joints"], strict=True):
            joint = w.joint("kuka", name).index
            before = [np.concatenate(w.pose(kuka, i)) for i in links]  # a link on the joint's axis only turns
            q = w.joint_states(kuka, [joint])[0][0]
            w.reset_joint(kuka, joint, q + 0.2, 0.0)
            moved = {i for i, p in zip(links, before, strict=True)
                     if np.linalg.norm(np.concatenate(w.pose(kuka, i)) - p) > 1e-6}
            w.reset_joint(kuka, joint, q, 0.0)
            assert len(moved) > 1 and finger == moved, name
