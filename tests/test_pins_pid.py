"""pid's promises against hand-derived values: step metrics of analytic responses, the I term's clamp, anti-windup
in the right direction, the D term's sign, the derivative filter's cut-off in Hz."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robokit_plugins.pid import step_metrics

from robokit.msgs import JointCommand
from robokit.testing import make_sim

JOINT = "lbr_iiwa_joint_1"  # the vertical axis: no gravity torque on it
DT = 1.0 / 240.0


def config(**gains: float) -> dict:
    return {"robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
            "actuators": {"pid": {"type": "pid", "body": "kuka", "joints": {JOINT: gains}}}}


# ---------------------------------------------------------------- step metrics on responses known in closed form
@settings(max_examples=60, deadline=None)
@given(tau=st.floats(0.05, 0.5), size=st.floats(-2.0, 2.0).filter(lambda s: abs(s) > 0.05))
def test_first_order_step_metrics(tau: float, size: float) -> None:
    """y = start + size (1 - exp(-t / tau)): rise 10->90 % = tau ln 9, 2 % settling = tau ln 50, no overshoot."""
    dt = 1e-3
    t = np.arange(0.0, 10 * tau, dt)
    start = 0.3
    y = start + size * (1.0 - np.exp(-t / tau))
    m = step_metrics(t, y, start, start + size)
    assert m.overshoot == 0.0
    assert m.rise_time == pytest.approx(tau * math.log(9.0), abs=2 * dt)
    settle = tau * math.log(50.0)
    assert settle - 1e-9 <= m.settling_time < settle + dt + 1e-9  # the first sample inside the band for good
    assert m.steady_error == pytest.approx(abs(size) * math.exp(-t[-1] / tau), rel=1e-6)


def test_underdamped_overshoot_matches_the_damping_ratio() -> None:
    zeta, wn = 0.3, 10.0
    wd = wn * math.sqrt(1 - zeta**2)
    t = np.arange(0.0, 5.0, 1e-4)
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    m = step_metrics(t, y, 0.0, 1.0)
    assert m.overshoot == pytest.approx(math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)), rel=1e-3)


def test_an_undershooting_response_has_no_overshoot_and_an_infinite_settling_time() -> None:
    t = np.linspace(0.0, 1.0, 101)
    y = 0.5 * (1 - np.exp(-t / 0.1))  # stops at half the step
    m = step_metrics(t, y, 0.0, 1.0)
    assert m.overshoot == 0.0
    assert m.settling_time == math.inf and m.rise_time == math.inf
    assert m.steady_error == pytest.approx(1.0 - y[-1])


def test_metrics_count_from_the_step_time() -> None:
    t = np.arange(0.0, 3.0, 1e-3)
    y = np.where(t < 1.0, 0.0, 1.0 - np.exp(-(t - 1.0) / 0.2))
    m = step_metrics(t, y, 0.0, 1.0, t_step=1.0)
    assert m.rise_time == pytest.approx(0.2 * math.log(9.0), abs=2e-3)
    assert m.settling_time == pytest.approx(0.2 * math.log(50.0), abs=2e-3)


# ---------------------------------------------------------------- the controller on a real joint
def run(gains: dict, setpoint: float, ticks: int) -> list:
    with make_sim(config(**gains)) as sim:
        sim.components["pid"].command(JointCommand("position", {JOINT: setpoint}))
        states = []
        for _ in range(ticks):
            sim.step(1)
            states.append(sim.readings["pid"])
    return states


def test_p_term_is_kp_times_the_error_and_d_term_opposes_the_motion() -> None:
    states = run({"kp": 50.0, "kd": 5.0, "max_torque": 300.0}, 0.5, 120)
    first = states[0]
    assert first.p_terms[JOINT] == pytest.approx(50.0 * 0.5, rel=1e-3)  # the joint has barely moved yet
    moving = [s for s in states if s.velocities[JOINT] > 0.05]
    assert moving, "the joint never moved towards the setpoint"
    assert all(s.d_terms[JOINT] < 0 for s in moving[1:])  # moving up: the D term pushes back
    assert all(s.i_terms[JOINT] == 0.0 for s in states)  # ki = 0


def test_the_integral_never_exceeds_integral_limit() -> None:
    states = run({"kp": 0.5, "ki": 200.0, "integral_limit": 3.0, "max_torque": 300.0}, 1.0, 240)
    terms = [s.i_terms[JOINT] for s in states]
    assert max(terms) == pytest.approx(3.0)  # reached the bound (200 * ~1 rad * 1 s would be ~200) and held it
    assert all(v <= 3.0 + 1e-12 for v in terms)


def test_anti_windup_freezes_the_integral_only_while_the_error_pushes_into_the_limit() -> None:
    """Saturated at +max_torque with a positive error: the I term stays 0. Saturated at +max_torque by a large
    feed-forward while the error is negative: integrating helps get out, so the I term goes negative."""
    pushing = run({"kp": 1000.0, "ki": 50.0, "max_torque": 5.0}, 1.0, 60)
    assert all(s.saturated[JOINT] for s in pushing)
    assert all(s.i_terms[JOINT] == 0.0 for s in pushing)
    unwinding = run({"kp": 1.0, "ki": 50.0, "max_torque": 5.0, "feed_forward": 100.0}, -0.2, 60)
    assert all(s.saturated[JOINT] for s in unwinding)
    assert unwinding[-1].i_terms[JOINT] < -0.1


@pytest.mark.parametrize("hz", [5.0, 50.0])
def test_difference_derivative_is_a_first_order_filter_with_its_cut_off_in_hz(hz: float) -> None:
    """A step of 1 mrad in the measured position, seen through the filter: the first output is
    alpha * (1e-3 / dt) with alpha = dt / (dt + 1 / (2 pi f))."""
    cfg = config(kp=0.0, kd=1.0, max_torque=10.0)
    cfg["actuators"]["pid"] |= {"derivative": "difference", "derivative_filter_hz": hz}
    with make_sim(cfg) as sim:
        pid = sim.components["pid"]
        q0 = pid.last_q.copy()
        rate = pid._filtered_rate(q0 + 1e-3, DT)
    alpha = DT / (DT + 1.0 / (2 * math.pi * hz))
    assert rate[0] == pytest.approx(alpha * 1e-3 / DT, rel=1e-9)
