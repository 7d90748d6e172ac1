"""diff_drive's promises (docs/mobile.md) as properties over generated commands, geometries and headings.

The oracle is the world and plain second computations written here:

- a Twist under a *configured* wheel radius and track that differ from the robot's: the wheels get
  ``(v -/+ omega * track / 2) / radius`` (scaled down together to ``max_wheel_speed``), and the base then moves as the
  robot's *own* wheels carry it (radius from the wheel links' height above the floor, track from their distance,
  both read from the world): its displacement in its own start frame over a window, at a heading that is no
  rotation's own inverse, against the closed-form arc;
- wheel speeds (the world's joint velocities) ramp at ``max_acceleration`` of rim speed, at any actuator rate,
  against a plain ramp computed in the test;
- odometry against the wheel angles read from the world and integrated here (mid-point heading, wrapped);
- Husky's two wheels a side: every joint of a side at that side's speed, the reading their mean;
- after a reset mid-drive the base comes to rest and the reading starts over at the true pose;
- a wheel joint that is not the robot's is refused at its own key and index.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.errors import ConfigError
from robokit.msgs.mobile import STOP, Twist, WheelSpeeds
from robokit.testing import PLANE, make_sim

DIFFBOT = {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}
HUSKY = {"urdf": "husky/husky.urdf", "position": [0, 0, 0.2]}
HUSKY_WHEELS = {"left_wheels": ["front_left_wheel", "rear_left_wheel"],
                "right_wheels": ["front_right_wheel", "rear_right_wheel"], "wheel_radius": 0.17775,
                "max_wheel_force": 50.0}


def scene(robot: dict[str, Any] = DIFFBOT, **drive: Any) -> dict[str, Any]:
    rate = drive.pop("rate_hz", None)
    section = {"type": "diff_drive", **drive, **({"rate_hz": rate} if rate else {})}
    return {"bodies": {"plane": PLANE}, "robots": {"robot": robot}, "actuators": {"drive": section}}


def place(w: Any, drive: Any, x: float, y: float, yaw: float, z: float = 0.06) -> None:
    """The robot at (x, y) turned by yaw, at rest, and the drive reset there."""
    w.set_pose(drive.body, [x, y, z], [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
    drive.reset()


def frame2d(w: Any, body: int) -> tuple[np.ndarray, float]:
    """The base link's (x, y) and heading from its rotation matrix's x axis."""
    pos, orn = w.pose(body)
    rot = np.asarray(w.matrix_from_quaternion(orn), float).reshape(3, 3)
    return np.asarray(pos[:2], float), math.atan2(rot[1, 0], rot[0, 0])


def wheel_geometry(w: Any, body: int) -> tuple[float, float]:
    """The diffbot's own wheel radius (the wheel axle's height over the floor at rest) and track (the distance
    between the two wheel axles), read from the world."""
    left = w.pose(body, w.link(body, "left_wheel_link"))[0]
    right = w.pose(body, w.link(body, "right_wheel_link"))[0]
    return 0.5 * (left[2] + right[2]), math.dist(left, right)


def commanded_wheels(v: float, omega: float, radius: float, track: float, limit: float) -> tuple[float, float]:
    """Wheel speeds a differential drive with this configured geometry sends, scaled together to the limit."""
    left, right = (v - omega * track / 2) / radius, (v + omega * track / 2) / radius
    peak = max(abs(left), abs(right))
    k = limit / peak if peak > limit else 1.0
    return left * k, right * k


headings = st.one_of(st.floats(0.25, 2.9), st.floats(-2.9, -0.25))  # never 0 or 180 degrees


@pytest.mark.slow
@settings(max_examples=10, deadline=None, derandomize=True)
@given(v=st.floats(-0.25, 0.25), omega=st.floats(-1.2, 1.2), yaw=headings, x=st.floats(-1, 1), y=st.floats(-1, 1),
       radius=st.floats(0.04, 0.07), track=st.floats(0.2, 0.34), limit=st.floats(2.0, 20.0))
def test_a_twist_carries_the_base_along_its_arc_in_its_own_frame(v: float, omega: float, yaw: float, x: float,
                                                                 y: float, radius: float, track: float,
                                                                 limit: float) -> None:
    with make_sim(scene(wheel_radius=radius, track_width=track, max_wheel_speed=limit)) as sim:
        w, drive = sim.world, sim.components["drive"]
        true_r, true_b = wheel_geometry(w, drive.body)
        place(w, drive, x, y, yaw)
        left, right = commanded_wheels(v, omega, radius, track, limit)
        v_true, w_true = true_r * (left + right) / 2, true_r * (right - left) / true_b  # the robot's own wheels
        drive.command(Twist(v, omega))
        sim.step(round(0.5 * w.physics_hz))  # past the ramp
        p0, h0 = frame2d(w, drive.body)
        window = round(0.5 * w.physics_hz)
        sim.step(window)
        p1, h1 = frame2d(w, drive.body)
        t = window / w.physics_hz
        c, s = math.cos(h0), math.sin(h0)
        d = p1 - p0
        local = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])  # in the start frame of the window
        turn = w_true * t
        arc = (np.array([math.sin(turn), 1 - math.cos(turn)]) * v_true / w_true if abs(w_true) > 1e-9
               else np.array([v_true * t, 0.0]))
        assert math.remainder(h1 - h0, 2 * math.pi) == pytest.approx(turn, rel=0.03, abs=0.01)
        assert np.allclose(local, arc, rtol=0.0, atol=0.03 * abs(v_true) * t + 0.002), (local, arc)
        assert drive.read().command == Twist(v, omega)


def plain_ramp(start: float, target: float, rate: float, elapsed: float) -> float:
    """A speed moving from start towards target at ``rate`` per second for ``elapsed`` seconds."""
    return start + max(-rate * elapsed, min(rate * elapsed, target - start))


@pytest.mark.slow
@settings(max_examples=8, deadline=None, derandomize=True)
@given(acc=st.floats(0.5, 4.0), hz=st.sampled_from([None, 120, 80, 60]), radius=st.floats(0.045, 0.06),
       commands=st.lists(st.tuples(st.floats(-8, 8), st.floats(-8, 8), st.integers(30, 120)), min_size=2,
                         max_size=3))
def test_wheel_speeds_ramp_at_max_acceleration_at_any_rate(acc: float, hz: int | None, radius: float,
                                                          commands: list[tuple[float, float, int]]) -> None:
    """The world's wheel joint velocities after each command stay within one actuator period of a plain ramp of
    ``max_acceleration / wheel_radius`` rad/s^2 from where they were to the commanded speeds."""
    with make_sim(scene(max_acceleration=acc, wheel_radius=radius, rate_hz=hz)) as sim:
        w, drive = sim.world, sim.components["drive"]
        place(w, drive, 0.0, 0.0, 0.7)
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        dt = 1.0 / w.physics_hz
        period = dt if hz is None else 1.0 / hz
        rate = acc / radius  # rad/s^2 of wheel
        for left, right, ticks in commands:
            start = [s[1] for s in w.joint_states(drive.body, joints)]
            drive.command(WheelSpeeds(left, right))
            for k in range(1, ticks + 1):
                sim.step(1)
                now = [s[1] for s in w.joint_states(drive.body, joints)]
                for got, s0, target in zip(now, start, (left, right), strict=True):
                    early = plain_ramp(s0, target, rate, max(0.0, k * dt - period - dt))
                    late = plain_ramp(s0, target, rate, k * dt + period)
                    lo, hi = min(early, late), max(early, late)
                    slack = 0.3 + 0.03 * abs(target)  # the wheel under load, the ground and the caster
                    assert lo - slack <= got <= hi + slack, (k, got, lo, hi)


@pytest.mark.slow
@settings(max_examples=6, deadline=None, derandomize=True)
@given(yaw=headings, radius=st.floats(0.04, 0.07), track=st.floats(0.2, 0.34),
       drives=st.lists(st.tuples(st.floats(-0.3, 0.3), st.floats(-2.5, 2.5), st.integers(20, 150)), min_size=1,
                       max_size=3))
def test_odometry_is_the_world_wheel_angles_integrated(yaw: float, radius: float, track: float,
                                                       drives: list[tuple[float, float, int]]) -> None:
    """With any configured geometry (even a wrong one), odometry is the wheel angles the world reports, turned
    into arc steps with that geometry and summed at the mid-point heading, starting from the true pose."""
    with make_sim(scene(wheel_radius=radius, track_width=track)) as sim:
        w, drive = sim.world, sim.components["drive"]
        place(w, drive, 0.4, -0.3, yaw)
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        p, h = frame2d(w, drive.body)
        odo = [float(p[0]), float(p[1]), h]
        assert np.allclose(drive.read().odometry[:2], odo[:2], atol=1e-6)
        assert abs(math.remainder(drive.read().odometry[2] - h, 2 * math.pi)) < 1e-6
        last = [s[0] for s in w.joint_states(drive.body, joints)]
        for v, omega, ticks in drives:
            drive.command(Twist(v, omega))
            for _ in range(ticks):
                # an actuator updates before the tick's physics step: what it has seen is the angles before it
                now = [s[0] for s in w.joint_states(drive.body, joints)]
                sim.step(1)
                dl, dr = now[0] - last[0], now[1] - last[1]
                last = now
                ds, dth = radius * (dl + dr) / 2, radius * (dr - dl) / track
                odo = [odo[0] + ds * math.cos(odo[2] + dth / 2), odo[1] + ds * math.sin(odo[2] + dth / 2),
                       odo[2] + dth]
            got = drive.read().odometry
            assert got[0] == pytest.approx(odo[0], abs=1e-7) and got[1] == pytest.approx(odo[1], abs=1e-7)
            assert abs(math.remainder(got[2] - odo[2], 2 * math.pi)) < 1e-7
            assert -math.pi <= got[2] < math.pi


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True)
@given(left=st.floats(-30, 30), right=st.floats(-30, 30), limit=st.floats(3.0, 12.0), yaw=headings)
def test_husky_every_wheel_of_a_side_turns_at_its_sides_clipped_speed(left: float, right: float, limit: float,
                                                                      yaw: float) -> None:
    """Two wheels a side: each joint of a side turns at that side's speed, both scaled down together to
    ``max_wheel_speed``; the reading's wheel speeds are each side's mean and odometry starts at the true pose."""
    with make_sim(scene(HUSKY, **HUSKY_WHEELS, max_wheel_speed=limit, max_acceleration=20.0)) as sim:
        w, drive = sim.world, sim.components["drive"]
        place(w, drive, 0.0, 0.0, yaw, z=0.2)
        start = drive.read()
        assert np.allclose(start.odometry, start.pose, atol=1e-6)
        sim.step(round(0.3 * w.physics_hz))
        peak = max(abs(left), abs(right), 1e-12)
        k = min(1.0, limit / peak)
        want = (left * k, right * k)
        drive.command(WheelSpeeds(left, right))
        sim.step(round(0.6 * w.physics_hz))
        sides = [[w.joint(drive.body, n).index for n in HUSKY_WHEELS[key]] for key in ("left_wheels", "right_wheels")]
        measured = [[s[1] for s in w.joint_states(drive.body, joints)] for joints in sides]
        for speeds, target in zip(measured, want, strict=True):
            for s in speeds:
                assert s == pytest.approx(target, rel=0.03, abs=0.1), (measured, want)
        reading = drive.read().wheel_speeds
        for got, speeds in zip(reading, measured, strict=True):
            assert got == pytest.approx(sum(speeds) / len(speeds), abs=1e-9)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True)
@given(v=st.floats(-0.3, 0.3), omega=st.floats(-1.5, 1.5), ticks=st.integers(40, 160), yaw=headings)
def test_a_reset_mid_drive_stops_the_base_and_starts_the_reading_over(v: float, omega: float, ticks: int,
                                                                      yaw: float) -> None:
    with make_sim(scene()) as sim:
        w, drive = sim.world, sim.components["drive"]
        place(w, drive, 0.0, 0.0, yaw)
        drive.command(Twist(v, omega))
        sim.step(ticks)
        drive.reset()
        p, h = frame2d(w, drive.body)
        r = drive.read()
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        sim.step(1)  # stopped at once, without the ramp: the wheels are held still from the next tick
        assert max(abs(s[1]) for s in w.joint_states(drive.body, joints)) < 0.3  # a wheel at rest jitters
        assert r.command == STOP and r.distance == 0.0
        assert np.allclose(r.odometry[:2], p, atol=1e-6) and abs(math.remainder(r.odometry[2] - h, 2 * math.pi)) < 1e-6
        sim.step(round(0.5 * w.physics_hz))
        at_rest, _ = frame2d(w, drive.body)
        sim.step(round(0.5 * w.physics_hz))
        p2, _ = frame2d(w, drive.body)
        assert math.dist(p2, at_rest) < 2e-3, "the base keeps moving after a reset"
        assert max(abs(s[1]) for s in w.joint_states(drive.body, joints)) < 0.3
        r2 = drive.read()
        assert r2.distance == pytest.approx(math.dist(p2, p), abs=0.02)
        drive.command(Twist(0.2, 0.0))
        sim.step(round(0.5 * w.physics_hz))
        assert drive.read().v > 0.15, "a new command drives again"


@pytest.mark.parametrize(("side", "names", "index"), [
    ("left_wheels", ["left_wheel", "nope"], 1), ("right_wheels", ["nope"], 0),
    ("passive_joints", ["caster_wheel", "left_wheel", "gone"], 2)])
def test_an_unknown_wheel_joint_is_refused_at_its_key_and_index(side: str, names: list[str], index: int) -> None:
    with pytest.raises(ConfigError) as err:
        make_sim(scene(**{side: names}))
    assert err.value.key is not None and err.value.key.endswith(f"{side}[{index}]"), err.value.key
    assert "nope" in str(err.value) or "gone" in str(err.value)
    assert "right_wheel" in str(err.value)  # the robot's joints are listed


def test_an_unknown_robot_is_refused_at_its_key_and_a_joints_error_names_the_robot() -> None:
    cfg = scene()
    cfg["actuators"]["drive"]["robot"] = "rover"
    with pytest.raises(ConfigError) as err:
        make_sim(cfg)
    assert err.value.key is not None and err.value.key.endswith("drive.robot") and "rover" in str(err.value)
    cfg = scene(left_wheels=["nope"])
    cfg["robots"] = {"rover": DIFFBOT}
    cfg["actuators"]["drive"]["robot"] = "rover"
    with pytest.raises(ConfigError, match="in rover"):
        make_sim(cfg)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True)
@given(left=st.floats(-1.0, 1.0), right=st.floats(-1.0, 1.0), limit=st.floats(0.2, 0.9))
def test_raw_wheel_speeds_below_one_rad_per_second_are_clipped_too(left: float, right: float, limit: float) -> None:
    """Any limit (here under 1 rad/s): the world's wheel speeds are the command scaled down together to it."""
    with make_sim(scene(max_wheel_speed=limit)) as sim:
        w, drive = sim.world, sim.components["drive"]
        drive.command(WheelSpeeds(left, right))
        sim.step(round(0.3 * w.physics_hz))
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        measured = [s[1] for s in w.joint_states(drive.body, joints)]
        k = min(1.0, limit / max(abs(left), abs(right), 1e-12))
        assert measured == pytest.approx([left * k, right * k], abs=0.03)


@pytest.mark.slow
@settings(max_examples=3, deadline=None, derandomize=True)
@given(limit=st.floats(0.02, 0.06), v=st.floats(0.2, 0.4), omega=st.floats(-1.0, 1.0))
def test_no_wheel_motor_pulls_harder_than_max_wheel_force(limit: float, v: float, omega: float) -> None:
    """A weak motor (the ramp asks for more than it can give): the world's applied motor torque of every wheel
    reaches the limit and never exceeds it."""
    with make_sim(scene(max_wheel_force=limit)) as sim:
        w, drive = sim.world, sim.components["drive"]
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        drive.command(Twist(v, omega))
        peak = 0.0
        for _ in range(60):
            sim.step(1)
            peak = max(peak, *(abs(s[3]) for s in w.joint_states(drive.body, joints)))
        assert peak == pytest.approx(limit, rel=1e-6)


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True)
@given(names=st.lists(st.sampled_from(["crate", "box", "ball", "ground"]), min_size=1, max_size=3, unique=True),
       yaw=headings)
def test_contacts_name_every_body_touching_the_robot_but_the_ground(names: list[str], yaw: float) -> None:
    """Small boxes dropped onto the robot and a plane called ``ground`` ignored like the floor: the reading names
    exactly the bodies the world says touch the robot, minus the ignored ones, in order."""
    with make_sim(scene()) as sim:
        w, drive = sim.world, sim.components["drive"]
        place(w, drive, 0.0, 0.0, yaw)
        top = w.body_aabb(drive.body)[1][2]
        for i, name in enumerate(names):
            w.add_primitive(name, "box", size=[0.03, 0.03, 0.03], mass=0.05,
                            position=[0.04 * math.cos(yaw + 2.1 * i), 0.04 * math.sin(yaw + 2.1 * i), top + 0.02])
        sim.step(60)
        touching = {w.body_name(c[2]) for c in w.client.getContactPoints(bodyA=w.body("robot"))}
        assert set(names) <= touching  # the scene does what it says
        state = drive.read()
        assert set(state.contacts) == touching - {"plane", "ground", "floor"}
        assert list(state.contacts) == sorted(state.contacts)


def test_a_protective_stop_mid_drive_holds_the_wheels_until_the_next_command() -> None:
    """Generated drives, each stopped mid-way: the world's wheels and base come to rest and stay there with no
    command (nothing drives on at the last command, not even ramped back up); the next command drives again."""
    rng = np.random.default_rng(11)
    with make_sim(scene()) as sim:
        w, drive = sim.world, sim.components["drive"]
        joints = [w.joint(drive.body, n).index for n in ("left_wheel", "right_wheel")]
        for _ in range(2):
            place(w, drive, 0.0, 0.0, float(rng.uniform(0.3, 2.8)))
            drive.command(Twist(float(rng.uniform(0.15, 0.3) * rng.choice([-1, 1])), float(rng.uniform(-1.5, 1.5))))
            sim.step(int(rng.integers(30, 90)))
            drive.protective_stop("a test")
            sim.step(round(0.3 * w.physics_hz))
            rest, _ = frame2d(w, drive.body)
            sim.step(round(0.3 * w.physics_hz))
            now, _ = frame2d(w, drive.body)
            assert math.dist(now, rest) < 2e-3, "the base drove on after the stop"
            assert max(abs(s[1]) for s in w.joint_states(drive.body, joints)) < 0.3
            assert drive.read().command == STOP
        drive.command(Twist(0.2, 0.0))
        sim.step(round(0.4 * w.physics_hz))
        assert drive.read().v > 0.1, "a new command drives again"
