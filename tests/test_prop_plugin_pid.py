"""The pid actuator against its documented law, tick by tick, on generated gains, limits and setpoints.

plugins/pid.py states the controller (``e = setpoint - position``; ``P = kp e``; ``I`` integrated with ``ki e dt``,
clamped to the integral limit and frozen while the output is saturated and ``e`` pushes further into it; ``D = -kd
d(position)/dt`` from the joint's velocity or a low-pass filtered difference; ``torque = clamp(P + I + D + ff)``),
the schedule of setpoint steps, and the step-response figures of ``step_metrics``. Here a second controller is
written plainly, one joint at a time in scalar Python from those sentences, and fed the positions and velocities
the test reads from the world before each tick; the plugin's reading must agree with it at every tick. The world is
the other oracle: with an integral term the joint ends at its setpoint.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st
from robokit_plugins.pid import step_metrics

from robokit.errors import ConfigError
from robokit.msgs import JointCommand
from robokit.testing import make_sim

NO_SHRINK = [Phase.explicit, Phase.generate]  # an example is a simulation: a failing one is reported as drawn

JOINTS = ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2"]  # a vertical axis and one that carries the arm's weight
DT = 1.0 / 240.0


class PlainPid:
    """One joint's controller, written from the plugin's docstring."""

    def __init__(self, gains: dict[str, float], limit: float, derivative: str, hz: float, q0: float) -> None:
        self.kp, self.ki, self.kd = gains["kp"], gains.get("ki", 0.0), gains.get("kd", 0.0)
        self.ff = gains.get("feed_forward", 0.0)
        self.limit = limit
        self.i_limit = gains.get("integral_limit") or limit
        self.derivative, self.hz = derivative, hz
        self.integral, self.rate, self.last_q, self.last_tick = 0.0, 0.0, q0, None

    def update(self, tick: int, setpoint: float, q: float, dq: float) -> tuple[float, float, float, float, bool]:
        dt = 0.0 if self.last_tick is None else (tick - self.last_tick) * DT
        self.last_tick = tick
        if self.derivative == "difference":
            if dt > 0:
                tau = 1.0 / (2.0 * math.pi * self.hz)  # first-order low-pass: y += dt / (dt + tau) * (x - y)
                self.rate += dt / (dt + tau) * ((q - self.last_q) / dt - self.rate)
            self.last_q = q
            dq = self.rate
        e = setpoint - q
        p, d = self.kp * e, -self.kd * dq
        before = p + self.integral + d + self.ff
        pushing_into_limit = abs(before) >= self.limit and (e > 0) == (before > 0) and e != 0 and before != 0
        if not pushing_into_limit:
            self.integral = max(-self.i_limit, min(self.i_limit, self.integral + self.ki * e * dt))
        out = p + self.integral + d + self.ff
        return p, self.integral, d, max(-self.limit, min(self.limit, out)), abs(out) > self.limit


gains_st = st.fixed_dictionaries(
    {"kp": st.floats(0.0, 400.0)},
    optional={"ki": st.floats(0.0, 300.0), "kd": st.floats(0.0, 40.0), "max_torque": st.floats(2.0, 300.0),
              "integral_limit": st.floats(0.5, 50.0), "feed_forward": st.floats(-10.0, 10.0)})


@settings(max_examples=8, deadline=None, derandomize=True, phases=NO_SHRINK)
@given(gains=st.tuples(gains_st, gains_st), derivative=st.sampled_from(["velocity", "difference"]),
       hz=st.floats(2.0, 100.0), period=st.sampled_from([1, 3]),
       setpoints=st.tuples(st.floats(-1.5, 1.5), st.floats(-1.0, 1.0)),
       schedule=st.tuples(st.floats(0.0, 0.25), st.floats(-1.5, 1.5)), command_at=st.integers(0, 40))
def test_every_tick_follows_the_documented_law(gains: tuple, derivative: str, hz: float, period: int,
                                               setpoints: tuple, schedule: tuple, command_at: int) -> None:
    """Start setpoints from the config for one joint (the other starts where it is), a scheduled step of joint 1
    at a generated time, a behaviour-like command at a generated tick; the actuator runs every ``period`` ticks."""
    at, step_to = schedule
    config = {
        "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "actuators": {"pid": {"type": "pid", "body": "kuka", "derivative": derivative, "derivative_filter_hz": hz,
                              "rate_hz": 240 / period,
                              "joints": dict(zip(JOINTS, gains, strict=True)),
                              "setpoints": {JOINTS[1]: setpoints[1]},
                              "schedule": [{"at": at, "setpoints": {JOINTS[0]: step_to}}]}},
    }
    with make_sim(config) as sim:
        w = sim.world
        body = w.body("kuka")
        idx = [w.joint("kuka", j).index for j in JOINTS]
        infos = [w.joint("kuka", j) for j in JOINTS]
        q0 = [s[0] for s in w.joint_states(body, idx)]
        limits = [g.get("max_torque") or (i.max_force if i.max_force > 0 else 100.0) for g, i in zip(gains, infos,
                                                                                                    strict=True)]
        plain = [PlainPid(g, lim, derivative, hz, q) for g, lim, q in zip(gains, limits, q0, strict=True)]
        target = [q0[0], setpoints[1]]
        pending = [(at, step_to)]
        for tick in range(90):
            if tick == command_at:
                sim.components["pid"].command(JointCommand("position", {JOINTS[0]: setpoints[0]}))
                target[0] = setpoints[0]
            states = [(s[0], s[1]) for s in w.joint_states(body, idx)]
            runs = tick % period == 0
            if runs and pending and pending[0][0] <= tick * DT + 1e-12:
                target[0] = pending.pop()[1]
            expected = [c.update(tick, sp, q, dq) for c, sp, (q, dq) in zip(plain, target, states, strict=True)] \
                if runs else None
            sim.step(1)
            if expected is None:
                continue
            r = sim.readings["pid"]
            for name, sp, (p, i, d, torque, saturated) in zip(JOINTS, target, expected, strict=True):
                assert r.setpoints[name] == pytest.approx(sp, abs=1e-12)
                assert r.p_terms[name] == pytest.approx(p, rel=1e-9, abs=1e-9), (tick, name)
                assert r.i_terms[name] == pytest.approx(i, rel=1e-9, abs=1e-9), (tick, name)
                assert r.d_terms[name] == pytest.approx(d, rel=1e-6, abs=1e-7), (tick, name)
                assert r.torques[name] == pytest.approx(torque, rel=1e-6, abs=1e-7), (tick, name)
                assert r.saturated[name] == saturated or abs(abs(torque) - limits[JOINTS.index(name)]) < 1e-9


@settings(max_examples=3, deadline=None, derandomize=True, phases=NO_SHRINK)
@given(setpoint=st.floats(-1.2, 1.2).filter(lambda s: abs(s) > 0.1), kp=st.floats(400.0, 700.0))
def test_with_an_integral_the_joint_ends_at_its_setpoint_in_the_world(setpoint: float, kp: float) -> None:
    """The arm's shoulder (it carries the arm's weight) under P, I and D: two seconds later it is at its setpoint
    and still, measured in the world."""
    config = {"robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
              "actuators": {"pid": {"type": "pid", "body": "kuka", "joints": {
                  j: {"kp": kp, "ki": 3 * kp, "kd": kp / 8, "max_torque": 300.0} for j in JOINTS}}}}
    with make_sim(config) as sim:
        sim.components["pid"].command(JointCommand("position", {JOINTS[1]: setpoint}))
        sim.step(480)
        w = sim.world
        q, dq = w.joint_states(w.body("kuka"), [w.joint("kuka", JOINTS[1]).index])[0][:2]
    assert q == pytest.approx(setpoint, abs=5e-3) and abs(dq) < 0.02


def plain_metrics(t: np.ndarray, y: np.ndarray, start: float, target: float, t_step: float,
                  band: float) -> tuple[float, float, float, float]:
    """Overshoot, rise time (10 -> 90 %), settling time (last entry into the band) and final error, by walking
    the samples one by one."""
    samples = [(ti - t_step, (yi - start) / (target - start), yi) for ti, yi in zip(t, y, strict=True)
               if ti >= t_step]
    peak = max(f for _, f, _ in samples)
    t10 = next((ti for ti, f, _ in samples if f >= 0.1), None)
    t90 = next((ti for ti, f, _ in samples if f >= 0.9), None)
    rise = t90 - t10 if t10 is not None and t90 is not None else math.inf
    settle = 0.0
    for k, (_, f, _) in enumerate(samples):
        if abs(f - 1.0) > band:
            settle = samples[k + 1][0] if k + 1 < len(samples) else math.inf
    return max(0.0, peak - 1.0), rise, settle, abs(target - samples[-1][2])


@settings(max_examples=60, deadline=None, derandomize=True)
@given(zeta=st.floats(0.1, 1.5), wn=st.floats(3.0, 30.0), start=st.floats(-1.0, 1.0),
       size=st.floats(-2.0, 2.0).filter(lambda s: abs(s) > 0.05), t_step=st.floats(0.0, 0.5),
       band=st.floats(0.01, 0.1), noise=st.integers(0, 2**16), length=st.floats(0.3, 3.0))
def test_step_metrics_agree_with_a_plain_walk_over_the_samples(zeta: float, wn: float, start: float, size: float,
                                                              t_step: float, band: float, noise: int,
                                                              length: float) -> None:
    """Second-order responses of generated damping and speed (some cut before they settle), with a little
    noise: every figure equals the one found by walking the samples."""
    t = np.arange(0.0, t_step + length, 2e-3)
    tau = np.clip(t - t_step, 0.0, None)
    if zeta < 1.0:
        wd = wn * math.sqrt(1 - zeta**2)
        unit = 1 - np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * tau))
    else:
        unit = 1 - np.exp(-wn * tau) * (1 + wn * tau)
    y = start + size * unit + np.random.default_rng(noise).normal(0.0, 0.002, len(t))
    m = step_metrics(t, y, start, start + size, t_step=t_step, band=band)
    want = plain_metrics(t, y, start, start + size, t_step, band)
    got = (m.overshoot, m.rise_time, m.settling_time, m.steady_error)
    for a, b in zip(got, want, strict=True):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("jump_at", [0, 1, 3])
def test_step_metrics_of_a_jump_agree_with_the_plain_walk_down_to_the_step_sample(jump_at: int) -> None:
    """A response that jumps to its target: already there at the step (settled at once), or one sample late with
    the step time falling exactly on a sample (that sample counts: the response is outside the band there)."""
    t = np.round(np.arange(0.0, 0.2, 0.01), 10)
    t_step = float(t[3])
    y = np.where(np.arange(len(t)) >= 3 + jump_at, 2.0, -1.0)
    m = step_metrics(t, y, -1.0, 2.0, t_step=t_step, band=0.02)
    want = plain_metrics(t, y, -1.0, 2.0, t_step, 0.02)
    assert (m.overshoot, m.rise_time, m.settling_time, m.steady_error) == pytest.approx(want, abs=1e-12)
    assert m.settling_time == pytest.approx(0.01 * jump_at, abs=1e-12)


def test_a_command_not_in_position_mode_or_for_a_joint_without_a_controller_is_refused_by_name() -> None:
    config = {"robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
              "actuators": {"pid": {"type": "pid", "body": "kuka", "joints": {j: {"kp": 50.0} for j in JOINTS}}}}
    with make_sim(config) as sim:
        pid = sim.components["pid"]
        with pytest.raises(ValueError, match="JointCommand\\('position'"):
            pid.command(JointCommand("velocity", {JOINTS[0]: 0.1}))
        with pytest.raises(ValueError, match=f"'lbr_iiwa_joint_7'.*controlled joints: {', '.join(JOINTS)}$"):
            pid.command(JointCommand("position", {"lbr_iiwa_joint_7": 0.1}))


@pytest.mark.slow
def test_config_mistakes_are_refused_at_their_keys_naming_the_controlled_joints() -> None:
    """A fixed joint under control, a setpoint or a scheduled step for a joint without a controller: each refused
    at its own key, the message naming the joint and, for the last two, the joints that are controlled."""
    def build(**pid: Any) -> None:
        config = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
                  "actuators": {"pid": {"type": "pid", "body": "panda", **pid}}}
        make_sim(config).close()

    joints = {"panda_joint1": {"kp": 50.0}, "panda_joint2": {"kp": 50.0}}
    with pytest.raises(ConfigError, match="'panda_hand_joint' is fixed") as err:
        build(joints={**joints, "panda_hand_joint": {"kp": 1.0}})
    assert err.value.key == "actuators.pid.joints.panda_hand_joint"
    listed = "controlled joints: panda_joint1, panda_joint2"
    with pytest.raises(ConfigError, match=f"'panda_joint3' has no controller; {listed}") as err:
        build(joints=joints, setpoints={"panda_joint3": 0.2})
    assert err.value.key == "actuators.pid.setpoints.panda_joint3"
    with pytest.raises(ConfigError, match=f"'panda_joint4' has no controller; {listed}") as err:
        build(joints=joints, schedule=[{"at": 0.1, "setpoints": {"panda_joint1": 0.1}},
                                       {"at": 0.2, "setpoints": {"panda_joint4": 0.1}}])
    assert err.value.key.startswith("actuators.pid.schedule") and err.value.key.endswith("panda_joint4")
