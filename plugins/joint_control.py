"""``joint_control`` actuator (lesson 03): drive named joints in position, velocity or torque mode.

Joints are named in config (default: every movable joint of the body). Each joint keeps its own mode and target:

- ``position``: targets in rad (or m), with a force limit (N·m or N) and an optional velocity limit (rad/s);
- ``velocity``: targets in rad/s, with a force limit;
- ``torque``: targets in N·m; the joint's default velocity motor is switched off first (velocity control with
  force 0), then the torque is applied every tick.

Without a behaviour the actuator can run a small **program** from its config: constant ``targets`` and ``sine``
waves per joint (``offset + amplitude * sin(2*pi*frequency_hz*t + phase)``), e.g. lesson 03's dance. A
:class:`~robokit.msgs.arm.JointCommand` from a behaviour overrides the program for the joints it names.

Safety stop (lesson 04): with ``stop_on = "<contact sensor>"``, the first tick that sensor reports a contact
freezes every joint where it is (position mode, holding) and ignores further targets; the reading says
``stopped`` with the reason.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any, ClassVar, Literal

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import ContactState, JointCommand, JointStates

Mode = Literal["position", "velocity", "torque"]


class SineWave(Schema):
    """One joint's wave: ``offset + amplitude * sin(2*pi*frequency_hz*t + radians(phase_deg))``."""

    amplitude: float
    frequency_hz: float = Field(gt=0)
    phase_deg: float = 0.0
    offset: float = 0.0


class JointControlConfig(Schema):
    """``[actuators.NAME]`` with ``type = "joint_control"``."""

    body: str = Field(description="the robot's body name")
    joints: tuple[str, ...] = Field((), description="joints to drive; default every movable joint")
    mode: Mode = Field("position", description="mode of the configured program")
    max_force: float | None = Field(None, gt=0, description="N·m (or N); default the URDF's limit")
    max_velocity: float | None = Field(None, gt=0, description="rad/s in position mode; default none")
    position_gain: float = Field(0.1, gt=0, le=1)
    targets: dict[str, float] = Field(default_factory=dict, description="joint -> constant target")
    sine: dict[str, SineWave] = Field(default_factory=dict, description="joint -> sine wave")
    stop_on: str | None = Field(None, description="a contact sensor; contact freezes every joint")


class JointControl(Actuator):
    """Drives named joints in position, velocity or torque mode; optional config program and contact stop."""

    reading_type = JointStates
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "kuka", "sine": {"lbr_iiwa_joint_1": {"amplitude": 0.5, "frequency_hz": 1.0}}},
        "robots": {"kuka": {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "commands": [(10, JointCommand("velocity", {"lbr_iiwa_joint_2": 0.5})),
                     (20, JointCommand("torque", {"lbr_iiwa_joint_7": 0.1}))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: JointControlConfig = self.config
        w = self.world
        self.body = ctx.body(cfg.body)
        names = cfg.joints or tuple(j.name for j in w.joints(cfg.body) if j.movable)
        self.joints = {name: self._joint(name, f"joints[{i}]") for i, name in enumerate(names)}
        for key, table in (("targets", cfg.targets), ("sine", cfg.sine)):
            for name in table:
                if name not in self.joints:
                    raise ConfigError(f"unknown joint {name!r}; driven joints: {', '.join(self.joints)}",
                                      key=f"{key}.{name}")
        if cfg.stop_on is not None:
            sensor = ctx.components.get(cfg.stop_on)
            if sensor is None or getattr(sensor, "reading_type", None) is not ContactState:
                raise ConfigError(f"{cfg.stop_on!r} is not a contact sensor; sensors: "
                                  f"{', '.join(ctx.components)}", key="stop_on")
        self.modes: dict[str, str] = {}
        self._any_torque = False
        self.values: dict[str, float] = {n: v for n, v in cfg.targets.items()}
        self.program = dict(cfg.sine)
        self._plan: list[tuple[Any, list[str]]] | None = None  # motor calls grouped by mode (see _make_plan)
        self._waves: list[tuple[str, float, float, float, float]] | None = None
        for name in set(cfg.targets) | set(cfg.sine):
            self._set_mode(name, cfg.mode)
        self.force: float | None = cfg.max_force
        self.max_velocity = cfg.max_velocity
        self.stopped, self.stop_reason = False, ""
        self.stopped_at: float | None = None
        self._dirty = True  # targets changed since they were last sent (a program changes them every update)
        self._indices = [j.index for j in self.joints.values()]

    def _joint(self, name: str, key: str) -> Any:
        info = self.ctx.joint(self.config.body, name, key=key)
        if not info.movable:
            raise ConfigError(f"joint {name!r} is {info.type}, not movable", key=key)
        return info

    def _set_mode(self, name: str, mode: str) -> None:
        if mode == "torque" and self.modes.get(name) != "torque":
            self.world.set_joint_motor(self.body, self.joints[name].index, "velocity", force=0.0)
        self.modes[name] = mode
        self._any_torque = "torque" in self.modes.values()  # PyBullet applies a torque for one step only
        self._plan = None

    def command(self, cmd: Any) -> None:
        """Accept a :class:`JointCommand`; the named joints leave the config program."""
        if not isinstance(cmd, JointCommand):
            raise ValueError(f"joint_control takes JointCommand, got {type(cmd).__name__}")
        unknown = [n for n in cmd.values if n not in self.joints]
        if unknown:
            raise ValueError(f"unknown joint {unknown[0]!r}; driven joints: {', '.join(self.joints)}")
        for name, value in cmd.values.items():
            self._set_mode(name, cmd.mode)
            self.values[name] = float(value)
            self.program.pop(name, None)
        self._plan = self._waves = None
        self._dirty = True
        if cmd.max_force is not None:
            self.force = cmd.max_force
            self._plan = None
        if cmd.max_velocity is not None:
            self.max_velocity = cmd.max_velocity

    def update(self) -> None:
        """Check the contact stop, evaluate the program at the current sim time, and drive every joint (motor
        targets are sent when they change: every update with a program, once after a command otherwise)."""
        if not self.stopped and self.config.stop_on is not None:
            contact: ContactState = self.ctx.readings[self.config.stop_on]
            if contact.in_contact:
                self._stop(contact)
        if self.stopped or not (self._dirty or self.program or self._any_torque):
            return
        self._dirty = False
        t, values, sin = self.world.time, self.values, math.sin
        if self._waves is None:
            self._waves = [(n, w.offset, w.amplitude, 2 * math.pi * w.frequency_hz, math.radians(w.phase_deg))
                           for n, w in self.program.items()]
        for name, offset, amplitude, omega, phase in self._waves:
            values[name] = offset + amplitude * sin(omega * t + phase)
        if self.max_velocity:  # only the per-joint call takes a velocity limit
            for name, value in values.items():
                self._drive(name, self.modes[name], value)
            return
        for call, names in self._plan or self._make_plan():
            call([values[n] for n in names])

    def _make_plan(self) -> list[tuple[Any, list[str]]]:
        """Group the joints by mode into one ``setJointMotorControlArray`` call each (rebuilt on mode changes)."""
        send = self.world.set_joint_motors
        groups: dict[str, list[str]] = {}
        for name in self.values:
            groups.setdefault(self.modes[name], []).append(name)
        plan: list[tuple[Any, list[str]]] = []
        for mode, names in groups.items():
            idx = [self.joints[n].index for n in names]
            forces = [self.force or (self.joints[n].max_force if self.joints[n].max_force > 0 else 100.0)
                      for n in names]
            if mode == "position":
                gains = [self.config.position_gain] * len(names)
                call = partial(send, self.body, idx, "position", forces=forces, position_gains=gains)
                plan.append((lambda v, f=call: f(target_positions=v), names))
            elif mode == "velocity":
                call = partial(send, self.body, idx, "velocity", forces=forces)
                plan.append((lambda v, f=call: f(target_velocities=v), names))
            else:
                call = partial(send, self.body, idx, "torque")
                plan.append((lambda v, f=call: f(forces=v), names))
        self._plan = plan
        return plan

    def _drive(self, name: str, mode: str, value: float) -> None:
        motor, info = self.world.set_joint_motor, self.joints[name]
        force = self.force or (info.max_force if info.max_force > 0 else 100.0)
        if mode == "position":
            motor(self.body, info.index, "position", target_position=value, force=force,
                  position_gain=self.config.position_gain, max_velocity=self.max_velocity or None)
        elif mode == "velocity":
            motor(self.body, info.index, "velocity", target_velocity=value, force=force)
        else:
            motor(self.body, info.index, "torque", force=value)

    def _stop(self, contact: ContactState) -> None:
        """Freeze every driven joint where it is now (position mode, zero target velocity)."""
        self.stopped, self.stopped_at = True, self.world.time
        touched = ", ".join(contact.others) or "something"
        self.stop_reason = f"contact with {touched} ({contact.normal_force:.1f} N) at t = {self.world.time:.3f} s"
        self.ctx.trace("safety_stop", actuator=self.name, reason=self.stop_reason)
        w = self.world
        states = w.joint_states(self.body, [j.index for j in self.joints.values()])
        for (name, info), state in zip(self.joints.items(), states, strict=True):
            self.modes[name], self.values[name] = "position", state[0]
            force = self.force or (info.max_force if info.max_force > 0 else 100.0)
            w.set_joint_motor(self.body, info.index, "position", target_position=state[0], target_velocity=0.0,
                              force=force, position_gain=self.config.position_gain)
        self.program.clear()
        self._plan = self._waves = None
        self._any_torque = False

    def _torque(self, name: str, motor_torque: float) -> float:
        """Applied torque: the motor's (position/velocity modes) or the commanded one (torque mode)."""
        if self.modes.get(name) == "torque" and not self.stopped:
            return float(self.values.get(name, 0.0))
        return float(motor_torque)

    def read(self) -> JointStates:
        """Position, velocity and applied torque (N·m or N) of every driven joint, by name."""
        states = self.world.joint_states(self.body, self._indices)
        names = list(self.joints)
        modes = set(self.modes.values())
        return JointStates(
            positions={n: float(s[0]) for n, s in zip(names, states, strict=True)},
            velocities={n: float(s[1]) for n, s in zip(names, states, strict=True)},
            torques={n: self._torque(n, s[3]) for n, s in zip(names, states, strict=True)},
            mode=modes.pop() if len(modes) == 1 else ("mixed" if modes else "position"),
            stopped=self.stopped, stop_reason=self.stop_reason, stopped_at=self.stopped_at,
        )


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("joint_control", JointControl, JointControlConfig)
