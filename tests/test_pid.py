"""The ``pid`` actuator on a real Kuka iiwa joint: step response, anti-windup, derivative on measurement, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robokit_plugins.pid import step_metrics

from robokit.msgs import JointCommand
from robokit.testing import edited_config, make_sim, validate_error

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pid_kuka.toml"
JOINT = "lbr_iiwa_joint_2"


def response(overrides: dict | None = None, seconds: float = 3.0) -> tuple[np.ndarray, np.ndarray, list]:
    with make_sim(CONFIG, overrides=overrides) as sim:
        t, q, states = [], [], []
        for _ in range(round(seconds / sim.world.time_step)):
            sim.step(1)
            s = sim.readings["pid"]
            t.append(sim.world.time)
            q.append(s.positions[JOINT])
            states.append(s)
    return np.array(t), np.array(q), states


def test_step_response_of_the_tuned_kuka_shoulder() -> None:
    """configs/pid_kuka.toml: 0 -> 0.5 rad at 0.5 s against gravity. Bounds: overshoot <= 8 %, 2 % settling
    <= 1.5 s, steady error <= 2 mrad (measured: 4.8 %, 1.31 s, 0.4 mrad)."""
    t, q, _ = response()
    assert abs(q[t < 0.5]).max() < 1e-3  # holds the start setpoint before the step
    m = step_metrics(t, q, 0.0, 0.5, t_step=0.5)
    assert m.overshoot <= 0.08, m
    assert m.settling_time <= 1.5, m
    assert m.steady_error <= 0.002, m
    assert 0.1 < m.rise_time < 0.5, m


def test_finite_difference_derivative_gives_the_same_response() -> None:
    t, q, _ = response({"actuators.pid.derivative": "difference", "actuators.pid.derivative_filter_hz": 60.0})
    m = step_metrics(t, q, 0.0, 0.5, t_step=0.5)
    assert m.overshoot <= 0.12 and m.settling_time <= 2.0 and m.steady_error <= 0.003, m


def slow_joint(max_torque: float, integral_limit: float) -> tuple[np.ndarray, np.ndarray, list]:
    """The Kuka's vertical axis (no gravity load) with a weak motor, stepped 0 -> 1 rad at t = 0."""
    config = {"robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
              "actuators": {"pid": {"type": "pid", "body": "kuka", "setpoints": {"lbr_iiwa_joint_1": 1.0},
                                    "joints": {"lbr_iiwa_joint_1": {"kp": 200.0, "ki": 400.0, "kd": 20.0,
                                                                    "max_torque": max_torque,
                                                                    "integral_limit": integral_limit}}}}}
    with make_sim(config) as sim:
        t, q, states = [], [], []
        for _ in range(4 * 240):
            sim.step(1)
            s = sim.readings["pid"]
            t.append(sim.world.time)
            q.append(s.positions["lbr_iiwa_joint_1"])
            states.append(s)
    return np.array(t), np.array(q), states


def test_output_limit_and_anti_windup_while_saturated() -> None:
    """With a 3 N·m limit the joint needs 0.2 s or more to get there: the output stays at the limit, and the
    integral does not grow while the output is saturated, so the arrival does not overshoot far."""
    t, q, states = slow_joint(3.0, 100.0)
    torques = np.array([s.torques["lbr_iiwa_joint_1"] for s in states])
    integral = np.array([s.i_terms["lbr_iiwa_joint_1"] for s in states])
    saturated = np.array([s.saturated["lbr_iiwa_joint_1"] for s in states])
    assert np.abs(torques).max() <= 3.0 + 1e-9
    assert saturated[t < 0.2].all()
    both = saturated[1:] & saturated[:-1]
    assert np.all(np.abs(integral[1:][both]) <= np.abs(integral[:-1][both]) + 1e-12)  # frozen, never wound up
    m = step_metrics(t, q, 0.0, 1.0)
    assert m.overshoot <= 0.10 and m.steady_error <= 0.002, m  # measured 5.1 %


def test_no_derivative_kick_when_the_setpoint_steps() -> None:
    _, _, states = response(seconds=0.51)
    first = next(s for s in states if s.setpoints[JOINT] == 0.5)
    assert first.d_terms[JOINT] == pytest.approx(0.0, abs=0.5)  # D acts on the measured rate, not on the error
    assert first.p_terms[JOINT] == pytest.approx(3000.0 * 0.5, rel=1e-3)


def test_behaviour_command_sets_a_setpoint() -> None:
    config = {"robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
              "actuators": {"pid": {"type": "pid", "body": "kuka",
                                    "joints": {"lbr_iiwa_joint_1": {"kp": 300.0, "ki": 50.0, "kd": 30.0}}}}}
    with make_sim(config) as sim:
        sim.components["pid"].command(JointCommand("position", {"lbr_iiwa_joint_1": 0.4}))
        sim.step(480)
        assert sim.readings["pid"].positions["lbr_iiwa_joint_1"] == pytest.approx(0.4, abs=0.01)
        with pytest.raises(ValueError, match="no controller"):
            sim.components["pid"].command(JointCommand("position", {"lbr_iiwa_joint_3": 0.1}))


def test_unknown_joint_is_one_line(tmp_path: Path) -> None:
    bad = edited_config(CONFIG, tmp_path, "joints.lbr_iiwa_joint_2]", "joints.lbr_iiwa_joint_9]")
    line = validate_error(bad)
    assert "actuators.pid.joints.lbr_iiwa_joint_9" in line and "lbr_iiwa_joint_2" in line
