"""``pid`` actuator (lesson 03's "torque control needs a PID controller you write yourself"): joint-space PID in
torque mode, one controller per joint, joints named in config.

Each update, for every joint (``e = setpoint - position``)::

    P = kp * e
    I = clamp(I + ki * e * dt, -integral_limit, +integral_limit)     (not while the output is saturated and e
                                                                       pushes further into the saturation)
    D = -kd * d(position)/dt                                          (derivative on measurement: no kick
                                                                       when the setpoint steps)
    torque = clamp(P + I + D + feed_forward, -max_torque, +max_torque)

The joint's default velocity motor is switched off first, so the torque is the only drive. ``d(position)/dt`` is
the joint velocity PyBullet reports (``derivative = "velocity"``) or a finite difference of the measured position
through a first-order low-pass filter (``derivative = "difference"``, ``derivative_filter_hz``), as a real encoder
would need. Units: radians (metres for prismatic joints), seconds, N·m (N).

Setpoints come from the config (``setpoints``, and a timed ``schedule`` of steps: the tuning program) or from a
behaviour as :class:`~robokit.msgs.arm.JointCommand` in ``position`` mode. The reading is a
:class:`PidState` with setpoints, measurements, the torque applied and each term, per joint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import JointCommand
from robokit.msgs.control import PidState


class PidGains(Schema):
    """One joint's controller. Gains in N·m per rad (``kp``), per rad·s (``ki``), per rad/s (``kd``)."""

    kp: float = Field(ge=0)
    ki: float = Field(0.0, ge=0)
    kd: float = Field(0.0, ge=0)
    max_torque: float | None = Field(None, gt=0, description="output limit, N·m; default the URDF's max force")
    integral_limit: float | None = Field(None, gt=0, description="bound of the I term, N·m; default max_torque")
    feed_forward: float = Field(0.0, description="constant torque added to the output, N·m")


class ScheduledStep(Schema):
    """At sim time ``at`` (s), set these joints' setpoints (rad): a step for tuning."""

    at: float = Field(ge=0)
    setpoints: dict[str, float]


class PidConfig(Schema):
    """``[actuators.NAME]`` with ``type = "pid"``."""

    body: str = Field(description="the robot's body name")
    joints: dict[str, PidGains] = Field(min_length=1, description="joint name -> gains")
    setpoints: dict[str, float] = Field(default_factory=dict, description="start setpoints; default: where it is")
    schedule: tuple[ScheduledStep, ...] = ()
    derivative: Literal["velocity", "difference"] = "velocity"
    derivative_filter_hz: float = Field(50.0, gt=0, description="low-pass cut-off of the 'difference' derivative")


class Pid(Actuator):
    """Joint-space PID in torque mode: gains, output limits, anti-windup, derivative on measurement, per joint."""

    reading_type = PidState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "kuka", "joints": {"lbr_iiwa_joint_1": {"kp": 300.0, "ki": 50.0, "kd": 30.0}}},
        "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "commands": [(10, JointCommand("position", {"lbr_iiwa_joint_1": 0.3}))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: PidConfig = self.config
        self.body = ctx.body(cfg.body)
        self.names = list(cfg.joints)
        infos = []
        for name in self.names:
            info = ctx.joint(cfg.body, name, key=f"joints.{name}")
            if not info.movable:
                raise ConfigError(f"joint {name!r} is {info.type}, not movable", key=f"joints.{name}")
            infos.append(info)
        self.index = [j.index for j in infos]
        gains = [cfg.joints[n] for n in self.names]
        self.kp = np.array([g.kp for g in gains])
        self.ki = np.array([g.ki for g in gains])
        self.kd = np.array([g.kd for g in gains])
        self.ff = np.array([g.feed_forward for g in gains])
        self.limit = np.array([g.max_torque or (j.max_force if j.max_force > 0 else 100.0)
                               for g, j in zip(gains, infos, strict=True)])
        self.i_limit = np.array([g.integral_limit or lim for g, lim in zip(gains, self.limit, strict=True)])
        for i, step in enumerate(cfg.schedule):
            self._check_names(step.setpoints, f"schedule[{i}].setpoints")
        self._check_names(cfg.setpoints, "setpoints")
        self.world.set_joint_motors(self.body, self.index, "velocity", forces=[0.0] * len(self.index))
        self.reset()

    def _check_names(self, table: dict[str, float], key: str) -> None:
        for name in table:
            if name not in self.names:
                raise ConfigError(f"joint {name!r} has no controller; controlled joints: {', '.join(self.names)}",
                                  key=f"{key}.{name}")

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Back to the start: setpoints from the config (else the measured positions), zero integral and filter."""
        cfg: PidConfig = self.config
        q, _ = self._measure()
        self.setpoint = np.array([cfg.setpoints.get(n, float(v)) for n, v in zip(self.names, q, strict=True)])
        self.integral = np.zeros(len(self.names))
        self.pending = sorted(cfg.schedule, key=lambda s: s.at)
        self.last_q, self.last_tick, self.dq_filtered = q, -1, np.zeros(len(self.names))
        zeros = np.zeros(len(self.names))
        self.terms = (zeros, zeros, zeros)
        self.torque, self.saturated = zeros, np.zeros(len(self.names), bool)

    def _measure(self) -> tuple[np.ndarray, np.ndarray]:
        states = self.world.joint_states(self.body, self.index)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def command(self, cmd: Any) -> None:
        """Accept a :class:`JointCommand` in ``position`` mode: new setpoints (rad) for the named joints."""
        if not isinstance(cmd, JointCommand) or cmd.mode != "position":
            raise ValueError(f"pid takes JointCommand('position', {{joint: setpoint}}), got {cmd!r}")
        for name, value in cmd.values.items():
            if name not in self.names:
                raise ValueError(f"joint {name!r} has no controller; controlled joints: {', '.join(self.names)}")
            self.setpoint[self.names.index(name)] = float(value)

    def update(self) -> None:
        """Apply due schedule steps, compute each joint's torque and send it (torque control)."""
        t = self.world.time
        while self.pending and self.pending[0].at <= t + 1e-12:
            for name, value in self.pending.pop(0).setpoints.items():
                self.setpoint[self.names.index(name)] = value
        dt = self.world.time_step * (self.world.tick - self.last_tick) if self.last_tick >= 0 else 0.0
        self.last_tick = self.world.tick
        q, dq = self._measure()
        if self.config.derivative == "difference":
            dq = self._filtered_rate(q, dt)
        error = self.setpoint - q
        p_term = self.kp * error
        d_term = -self.kd * dq
        unclamped = p_term + self.integral + d_term + self.ff
        # anti-windup (conditional integration): freeze the integral where the output is saturated and the error
        # would push it further into the limit
        winding = (np.abs(unclamped) >= self.limit) & (np.sign(error) == np.sign(unclamped))
        self.integral = np.where(winding, self.integral,
                                 np.clip(self.integral + self.ki * error * dt, -self.i_limit, self.i_limit))
        out = p_term + self.integral + d_term + self.ff
        self.torque = np.clip(out, -self.limit, self.limit)
        self.saturated = np.abs(out) > self.limit
        self.terms = (p_term, self.integral.copy(), d_term)
        self.world.set_joint_motors(self.body, self.index, "torque", forces=self.torque.tolist())

    def _filtered_rate(self, q: np.ndarray, dt: float) -> np.ndarray:
        """Finite-difference joint rate through a first-order low-pass filter (rad/s)."""
        if dt <= 0:
            self.last_q = q
            return self.dq_filtered
        raw = (q - self.last_q) / dt
        alpha = dt / (dt + 1.0 / (2 * math.pi * self.config.derivative_filter_hz))
        self.dq_filtered = self.dq_filtered + alpha * (raw - self.dq_filtered)
        self.last_q = q
        return self.dq_filtered

    def read(self) -> PidState:
        """Setpoints, measurements, torques and the P/I/D terms by joint name."""
        q, dq = self._measure()

        def by_name(values: np.ndarray) -> dict[str, float]:
            return {n: float(v) for n, v in zip(self.names, values, strict=True)}

        return PidState(
            setpoints=by_name(self.setpoint), positions=by_name(q), velocities=by_name(dq),
            torques=by_name(self.torque), p_terms=by_name(self.terms[0]), i_terms=by_name(self.terms[1]),
            d_terms=by_name(self.terms[2]),
            saturated={n: bool(s) for n, s in zip(self.names, self.saturated, strict=True)},
        )


@dataclass(frozen=True)
class StepMetrics:
    """A step response's figures: ``overshoot`` as a fraction of the step, times in seconds after the step
    (``settling_time``: last entry into the ±``band`` band; ``rise_time``: 10 % → 90 %), ``steady_error`` in the
    response's unit at the end."""

    overshoot: float
    rise_time: float
    settling_time: float
    steady_error: float


def step_metrics(t: Any, y: Any, start: float, target: float, *, t_step: float = 0.0,
                 band: float = 0.02) -> StepMetrics:
    """Overshoot, rise time, settling time and steady-state error of a step from ``start`` to ``target``.

    Args:
        t: Sample times, seconds. y: The measured response at those times.
        t_step: When the setpoint stepped. band: Settling band as a fraction of the step size.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    keep = t >= t_step
    t, y = t[keep] - t_step, y[keep]
    size = target - start
    frac = (y - start) / size
    overshoot = max(0.0, float(frac.max()) - 1.0)
    above10, above90 = np.flatnonzero(frac >= 0.1), np.flatnonzero(frac >= 0.9)
    rise = float(t[above90[0]] - t[above10[0]]) if len(above90) and len(above10) else math.inf
    outside = np.flatnonzero(np.abs(frac - 1.0) > band)
    if len(outside) == 0:
        settling = 0.0
    elif outside[-1] == len(t) - 1:
        settling = math.inf
    else:
        settling = float(t[outside[-1] + 1])
    return StepMetrics(overshoot, rise, settling, float(abs(target - y[-1])))


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("pid", Pid, PidConfig)
