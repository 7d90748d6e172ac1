"""Core promises, expectations derived independently: a component's period from its rate, events at their tick,
lazy sensors computed only when read (and counted), a finished behaviour no longer stepped, GUI pacing against an
injected clock, yaw of a quaternion (Hypothesis), mounts in both directions, seeded sampling's spacing and
clearance, whole-body boxes, quaternion normalisation, state machines' phase times and per-state timeouts."""

from __future__ import annotations

import enum
import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit import hookimpl
from robokit.components import Behaviour
from robokit.config import Schema
from robokit.core.world import World, to_quaternion, yaw_of
from robokit.testing import PLANE, make_sim

ROOT = Path(__file__).resolve().parents[1]
CUBE = {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.05]}


class NoOptions(Schema):
    """No options."""


class ThreeSteps(Behaviour):
    """Records the sim time of every step and succeeds at the third."""

    def setup(self, ctx):  # type: ignore[no-untyped-def]
        super().setup(ctx)
        self.times: list[float] = []

    def step(self, readings, t):  # type: ignore[no-untyped-def]
        self.times.append(t)
        if len(self.times) == 3:
            self.finish("succeeded", "three steps")
        return None


class Plugin:
    @hookimpl
    def robokit_register_behaviours(self, register):  # type: ignore[no-untyped-def]
        register("three_steps", ThreeSteps, NoOptions)


def scene(**extra: object) -> dict:
    return {"world": {"max_time": 1.0}, "bodies": {"plane": PLANE, "cube": CUBE}, **extra}


# ------------------------------------------------------------------ scheduler
@pytest.mark.parametrize(("hz", "period"), [(60, 4), (120, 2), (240, 1), (30, 8)])
def test_a_sensor_at_rate_hz_is_due_every_physics_hz_over_rate_ticks(hz: int, period: int) -> None:
    with make_sim(scene(sensors={"pose": {"type": "body_pose", "bodies": ["cube"], "rate_hz": hz}})) as sim:
        stamps = []
        for _ in range(3 * period):
            sim.step(1)
            sim.readings["pose"]  # noqa: B018 - reading computes it if due
            stamps.append(sim.readings.stamp("pose"))
    distinct = sorted(set(stamps))  # a new reading every `period` ticks, stamped when it was computed
    assert len(distinct) == 3 and np.diff(distinct).tolist() == [period, period]


def test_a_lazy_sensor_nobody_reads_is_never_computed_and_each_read_when_due_counts_once() -> None:
    with make_sim(scene(sensors={"pose": {"type": "body_pose", "bodies": ["cube"], "rate_hz": 60}})) as sim:
        sim.step(40)
        assert sim.readings.computed("pose") == 0
        for _ in range(3):
            sim.readings["pose"]  # noqa: B018
            sim.readings["pose"]  # noqa: B018 - a second read of the same due reading: not computed again
            sim.step(4)
        assert sim.readings.computed("pose") == 3


def test_an_event_acts_at_its_tick() -> None:
    """set_pose at t = 0.1 s = tick 24: applied after the actuators of tick 24, so the pose read at the start of
    tick 24 is the old one and at tick 25 the new one."""
    events = [{"at": 0.1, "type": "set_pose", "body": "cube", "position": [1.0, 0.0, 0.05]}]
    with make_sim(scene(events=events)) as sim:
        sim.step(24)
        assert sim.world.pose("cube")[0][0] == pytest.approx(0.0, abs=1e-3)
        sim.step(1)
        assert sim.world.pose("cube")[0][0] == pytest.approx(1.0, abs=1e-3)


def test_a_finished_behaviour_is_not_stepped_again() -> None:
    with make_sim(scene(behaviour={"type": "three_steps"}), extra_plugins=[Plugin()]) as sim:
        sim.step(20)
        times = sim.behaviour.times
    assert times == pytest.approx([0.0, 1 / 240, 2 / 240])


def test_pacing_sleeps_exactly_as_far_as_sim_time_runs_ahead() -> None:
    """A wall clock that moves only when slept: 240 paced ticks sleep 1 s in all, and never when behind."""
    now = [100.0]
    slept: list[float] = []

    def sleep(s: float) -> None:
        slept.append(s)
        now[0] += s

    with make_sim(scene()) as sim:
        sched = sim.scheduler
        sched.wall_clock, sched.sleep = (lambda: now[0]), sleep
        sched.start_pacing()
        for _ in range(240):
            sched.tick()
            sched.pace()
        assert sum(slept) == pytest.approx(1.0)
        now[0] += 5.0  # the wall clock jumps ahead: sim time is behind, no sleep
        before = len(slept)
        sched.tick()
        sched.pace()
        assert len(slept) == before


# ------------------------------------------------------------------ world
@settings(max_examples=300, deadline=None)
@given(roll=st.floats(-1.4, 1.4), pitch=st.floats(-1.4, 1.4), yaw=st.floats(-3.1, 3.1))
def test_yaw_of_recovers_the_yaw_of_roll_pitch_yaw(roll: float, pitch: float, yaw: float) -> None:
    q = p.getQuaternionFromEuler([roll, pitch, yaw])
    assert math.remainder(yaw_of(q) - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


def test_to_quaternion_normalises() -> None:
    assert to_quaternion(quaternion=(0.0, 0.0, 2.0, 0.0)) == pytest.approx((0.0, 0.0, 1.0, 0.0))
    assert to_quaternion(quaternion=(1.0, 1.0, 1.0, 1.0)) == pytest.approx((0.5, 0.5, 0.5, 0.5))


def test_attached_follows_mounts_up_and_down() -> None:
    cfg = {"bodies": {
        "holder": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 0, "position": [0, 0, 0.5]},
        "adapter": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1,
                    "mount": {"body": "holder", "link": "base", "position": [0.15, 0, 0]}},
        "cup": {"shape": "cylinder", "radius": 0.03, "height": 0.02, "mass": 0.05,
                "mount": {"body": "adapter", "link": "base", "position": [0, 0, -0.05]}},
        "loose": CUBE}}
    with make_sim(cfg) as sim:
        w = sim.world
        group = {w.body(n) for n in ("holder", "adapter", "cup")}
        assert w.attached("cup") == w.attached("adapter") == w.attached("holder") == group
        assert w.attached("loose") == {w.body("loose")}


@pytest.mark.parametrize("seed", range(5))
def test_sampled_positions_keep_their_spacing_from_existing_points_and_clearance_from_boxes(seed: int) -> None:
    with World(seed=seed) as w:
        existing = [(0.0, 0.0)]
        box = ((0.3, -0.1, 0.0), (0.5, 0.1, 0.1))
        pts = w.sample_positions(6, (-0.6, -0.6), (0.6, 0.6), min_spacing=0.15, avoid=[box], clearance=0.05,
                                 existing=existing)
    for a in pts:
        assert math.dist(a, existing[0]) >= 0.15
        inside = 0.25 <= a[0] <= 0.55 and -0.15 <= a[1] <= 0.15  # the box grown by the clearance
        assert not inside
    for i in range(len(pts)):
        for j in range(i):
            assert math.dist(pts[i], pts[j]) >= 0.15


def test_body_aabb_spans_every_link_base_included() -> None:
    cfg = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}}}
    with make_sim(cfg) as sim:
        w = sim.world
        bid = w.body("panda")
        boxes = [w.client.getAABB(bid, link) for link in range(-1, w.client.getNumJoints(bid))]
        lo, hi = w.body_aabb("panda")
        base_low = w.client.getAABB(bid, -1)[0][2]
    assert lo == pytest.approx(tuple(np.min([b[0] for b in boxes], axis=0)))
    assert hi == pytest.approx(tuple(np.max([b[1] for b in boxes], axis=0)))
    assert lo[2] <= base_low + 1e-12


# ------------------------------------------------------------------ state machines
def test_phase_times_add_up_to_the_time_spent_and_states_time_out_from_their_own_entry() -> None:
    """A clean pick and place (every state well inside its own timeout, the whole run longer than several):
    succeeds, and the times per state sum to the time before the last state was entered."""
    with make_sim(ROOT / "configs" / "pick_place.toml") as sim:
        result = sim.run()
        entered = sim.behaviour.entered_at
    assert result.outcome == "succeeded", result.reason
    times = result.result["phase_times"]
    assert result.result["sim_time"] > 2.0  # longer than GRASP's 1 s, LIFT's and RETREAT's 2 s from the start
    assert sum(times.values()) == pytest.approx(entered, abs=1e-6)
    assert all(0 <= v <= 3.0 for v in times.values())


def test_state_timeouts_count_from_each_states_entry() -> None:
    """The sort looks (LOOK: 1 s timeout) again after each pick, seconds into the run: those looks do not time out,
    and the two-cube sort succeeds."""
    overrides = {"bodies.red.count": 1, "bodies.blue.count": 1, "sensors.truth.bodies": ["red", "blue"]}
    with make_sim(ROOT / "configs" / "sort_robot.toml", overrides=overrides) as sim:
        result = sim.run()
        looks = [r["t"] for r in sim.trace if r.get("kind") == "transition" and r.get("dest_state") == "LOOK"]
    assert result.outcome == "succeeded", result.reason
    assert max(looks) > 2.0  # a LOOK entered long after the run's first second


class _Gate(enum.Enum):
    SHUT = "shut"
    OPEN = "open"


def test_fire_says_whether_a_transition_ran_self_transitions_included() -> None:
    """``fire`` is True when the state changed or a self-transition re-entered it (entry time reset, one more
    visit), False when a condition held the transition back (nothing entered)."""
    from robokit.fsm import MachineBehaviour

    class Gate(MachineBehaviour):
        STATES = _Gate
        INITIAL = _Gate.SHUT
        TRANSITIONS = [{"trigger": "push", "source": "SHUT", "dest": "OPEN", "conditions": "unlocked"},
                       {"trigger": "retry", "source": "SHUT", "dest": "SHUT"}]
        unlocked = False

    gate = Gate("gate", None)
    gate.t = 0.0
    gate.t = 1.5
    assert gate.fire("push") is False and gate.state_name == "SHUT" and gate.visited == ["SHUT"]
    assert gate.fire("retry") is True and gate.state_name == "SHUT" and gate.visited == ["SHUT", "SHUT"]
    assert gate.entered_at == 1.5
    gate.unlocked = True
    assert gate.fire("push") is True and gate.visited == ["SHUT", "SHUT", "OPEN"]
