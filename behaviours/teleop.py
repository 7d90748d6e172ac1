"""Keyboard teleoperation (lesson 03's joint control, lesson 07's RC driving).

Both behaviours read a ``keyboard`` sensor (GUI keys, or a timed script when headless) and send commands every
step. They are open-ended: they end when the quit key is pressed, and reaching ``max_time`` counts as success.

A key held moves for as long as it is held; a key tapped between two readings (in ``pressed`` but no longer in
``down``) still counts for one step. Joint targets stay inside the joints' limits (the URDF's, as the
``joint_control`` actuator resolved them); continuous joints are not clamped.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import JointCommand
from robokit.msgs.mobile import Twist


def _need(ctx: SetupContext, name: str, key: str, what: str) -> None:
    if name not in ctx.components:
        raise ConfigError(f"no component named {name!r} (expected {what})", key=key)


class JointTeleopConfig(Schema):
    """Keys 1-9 select a joint from ``joints``; left/right arrows move its target at ``speed`` rad/s."""

    keyboard: str = "keys"
    actuator: str = "joints"
    joints: tuple[str, ...] = Field(min_length=1, max_length=9)
    speed: float = Field(1.0, gt=0, description="rad/s while an arrow is held")
    quit_key: str = "q"


class JointTeleop(Behaviour):
    """Lesson 03: select a joint with keys 1-9 and turn it with the left/right arrows."""
    COMMANDS: ClassVar[tuple[str, ...]] = ("actuator",)

    open_ended: ClassVar[bool] = True

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        _need(ctx, self.config.keyboard, "keyboard", "a keyboard sensor")
        _need(ctx, self.config.actuator, "actuator", "a joint_control actuator")
        self.limits = self._limits(ctx)
        self.selected = 0
        self.targets: dict[str, float] = {}
        self.last_t: float | None = None  # sim time of the previous step (None before the first)
        self.selections: list[str] = []

    def _limits(self, ctx: SetupContext) -> dict[str, tuple[float, float]]:
        """Lower and upper limit of each teleoperated joint (rad or m), from the actuator's resolved joints."""
        driven = getattr(ctx.components[self.config.actuator], "joints", None)
        if not isinstance(driven, Mapping):
            return {}
        limits = {}
        for i, name in enumerate(self.config.joints):
            if name not in driven:
                raise ConfigError(f"joint {name!r} is not driven by {self.config.actuator!r}; driven joints: "
                                  f"{', '.join(driven)}", key=f"joints[{i}]")
            lower, upper = getattr(driven[name], "lower", 0.0), getattr(driven[name], "upper", -1.0)
            if upper > lower:  # URDF continuous joints give upper <= lower: no limit
                limits[name] = (float(lower), float(upper))
        return limits

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        cfg = self.config
        if not self.targets:
            positions = readings[cfg.actuator].positions
            self.targets = {name: self._clamp(name, float(positions[name])) for name in cfg.joints}
        keys = readings[cfg.keyboard]
        if cfg.quit_key in keys.pressed:
            self.finish("succeeded", f"quit key {cfg.quit_key!r} pressed")
        for i in range(len(cfg.joints)):
            if str(i + 1) in keys.pressed:
                self.selected = i
                self.selections.append(cfg.joints[i])
        dt, self.last_t = t - (t if self.last_t is None else self.last_t), t
        active = keys.down | keys.pressed  # a tap released before this reading still moves one step
        direction = ("right" in active) - ("left" in active)
        name = cfg.joints[self.selected]
        self.targets[name] = self._clamp(name, self.targets[name] + direction * cfg.speed * dt)
        return {cfg.actuator: JointCommand("position", dict(self.targets))}

    def _clamp(self, name: str, value: float) -> float:
        lower, upper = self.limits.get(name, (-math.inf, math.inf))
        return min(upper, max(lower, value))

    def result(self) -> dict[str, Any]:
        return {"targets": {k: round(v, 6) for k, v in self.targets.items()}, "selections": self.selections}


class DriveTeleopConfig(Schema):
    """Arrow keys drive a ``diff_drive``: up/down at ``speed`` m/s, left/right turn at ``turn`` rad/s."""

    keyboard: str = "keys"
    actuator: str = "drive"
    speed: float = Field(0.5, gt=0, description="m/s")
    turn: float = Field(1.5, gt=0, description="rad/s")
    quit_key: str = "q"


class DriveTeleop(Behaviour):
    """Lesson 07: drive a differential-drive robot with the arrow keys."""

    COMMANDS: ClassVar[tuple[str, ...]] = ("actuator",)

    open_ended: ClassVar[bool] = True

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        _need(ctx, self.config.keyboard, "keyboard", "a keyboard sensor")
        _need(ctx, self.config.actuator, "actuator", "a diff_drive actuator")
        self.commands = 0
        self.pose: tuple[float, float, float] | None = None

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        cfg = self.config
        keys = readings[cfg.keyboard]
        if cfg.quit_key in keys.pressed:
            self.finish("succeeded", f"quit key {cfg.quit_key!r} pressed")
        active = keys.down | keys.pressed  # a tap released before this reading still counts for one step
        v = cfg.speed * (("up" in active) - ("down" in active))
        omega = cfg.turn * (("left" in active) - ("right" in active))
        self.commands += 1
        self.pose = tuple(readings[cfg.actuator].pose)  # type: ignore[assignment]
        return {cfg.actuator: Twist(v, omega)}

    def halt(self, t: float) -> Mapping[str, Any] | None:
        """Stopped before it ended (a composite's timeout, a monitor): the robot stops, whatever key is held."""
        return {self.config.actuator: Twist(0.0, 0.0)}

    def result(self) -> dict[str, Any]:
        pose = [round(v, 4) for v in self.pose] if self.pose else None
        return {"commands": self.commands, "final_pose": pose}


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("joint_teleop", JointTeleop, JointTeleopConfig)
    register("drive_teleop", DriveTeleop, DriveTeleopConfig)
