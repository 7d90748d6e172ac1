"""``diff_drive`` actuator (lesson 07): a differential- or skid-steer drive with wheel joints found by name.

A command is a :class:`~robokit.msgs.mobile.Twist` ``(v, omega)`` in m/s and rad/s, turned into wheel
speeds with the wheel radius and track width, or raw :class:`~robokit.msgs.mobile.WheelSpeeds` in rad/s.
Every listed wheel joint of a side gets that side's speed under velocity control, limited by ``max_wheel_force``.
Passive joints (a caster) have their default velocity motor switched off. The reading is a
:class:`~robokit.msgs.mobile.DriveState`: ground-truth planar pose and velocity, wheel odometry, distance
travelled, and the names of bodies touching the robot (collision counting). A protective stop (a monitor that aborts
or recovers) sets the wheels' target speeds to zero at once, until the next command.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError
from robokit.msgs.mobile import STOP, DriveState, Twist, WheelSpeeds, wrap_angle


class DiffDriveConfig(Schema):
    """Config of ``diff_drive``. Defaults fit the bundled ``robots/diffbot.urdf``.

    Attributes:
        robot: Body name of the robot.
        left_wheels: Wheel joint names on the left side (one for a differential drive, two for Husky).
        right_wheels: Wheel joint names on the right side.
        wheel_radius: m.
        track_width: Distance between the left and right wheel contact lines, m (for skid-steer robots an
            effective value larger than the geometric one accounts for scrubbing).
        max_wheel_force: Motor torque limit per wheel, N·m.
        max_wheel_speed: Wheel speeds are clipped to this, rad/s (a Twist is scaled down to keep its curvature).
        max_acceleration: Wheel rim speed changes at most this fast, m/s^2 (keeps the robot from pitching).
        passive_joints: Joints whose default motor is switched off (casters).
        ignore_contacts: Bodies not reported as contacts (the ground).
    """

    robot: str = "robot"
    left_wheels: tuple[str, ...] = Field(("left_wheel",), min_length=1)
    right_wheels: tuple[str, ...] = Field(("right_wheel",), min_length=1)
    wheel_radius: float = Field(0.05, gt=0)
    track_width: float = Field(0.26, gt=0)
    max_wheel_force: float = Field(5.0, gt=0)
    max_wheel_speed: float = Field(20.0, gt=0)
    max_acceleration: float = Field(2.0, gt=0)
    passive_joints: tuple[str, ...] = ("caster_wheel",)
    ignore_contacts: tuple[str, ...] = ("plane", "ground", "floor")


class DiffDrive(Actuator):
    """Differential/skid-steer drive: (v, omega) or raw wheel speeds; pose, velocity and wheel odometry."""

    reading_type = DriveState
    example: ClassVar[dict[str, Any]] = {
        "config": {"robot": "robot"},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
        "commands": [(0, Twist(0.2, 0.0)), (24, Twist(0.0, 1.0))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg = self.config
        self.body = ctx.body(cfg.robot, key="robot")
        self.left = self._joints(cfg.left_wheels, "left_wheels")
        self.right = self._joints(cfg.right_wheels, "right_wheels")
        self._both = self.left + self.right
        default_caster = "passive_joints" not in cfg.model_fields_set  # robots without a caster skip it
        passive = self._joints(cfg.passive_joints, "passive_joints", skip_missing=default_caster)
        for j in passive:
            self.world.set_joint_motor(self.body, j, "velocity", target_velocity=0.0, force=0.0)
        self.reset()

    def reset(self, rng: Any = None) -> None:
        """The start state (also between robokit.gym episodes): stopped, odometry at the current true pose."""
        self.cmd: Twist | WheelSpeeds = STOP
        self.targets = (0.0, 0.0)
        self.speeds = (0.0, 0.0)
        self.last_tick = -1
        x, y, yaw = self._pose()
        self.odom = [x, y, yaw]
        self.last_pose = (x, y)
        self.distance = 0.0
        self.last_wheels = self._wheel_angles()
        self._sent: tuple[float, ...] | None = None
        self.update()

    def _joints(self, names: tuple[str, ...], key: str, skip_missing: bool = False) -> list[int]:
        """Joint indices by name; unknown names are config errors listing the body's joints."""
        out = []
        valid = [j.name for j in self.world.joints(self.body)]
        for i, name in enumerate(names):
            if name not in valid:
                if skip_missing:
                    continue
                err = LookupNameError("joint", name, valid, where=self.config.robot)
                raise ConfigError(str(err), key=f"{key}[{i}]")
            out.append(self.world.joint(self.body, name).index)
        return out

    def command(self, cmd: Any) -> None:
        """Accept a :class:`Twist` or :class:`WheelSpeeds`."""
        if not isinstance(cmd, (Twist, WheelSpeeds)):
            raise ValueError(f"diff_drive takes a Twist(v, omega) or WheelSpeeds(left, right), got {cmd!r}")
        self.cmd = cmd
        self.targets = self.wheel_targets(cmd)

    def protective_stop(self, reason: str) -> None:
        """Stop now (a monitor that aborts or recovers): the wheel motors' targets go to zero in this tick, without
        the acceleration ramp, and stay there until a new command; nothing drives on at the last command."""
        self.cmd, self.targets, self.speeds = STOP, (0.0, 0.0), (0.0, 0.0)
        self.world.set_joint_motors(self.body, self._both, "velocity", target_velocities=[0.0] * len(self._both),
                                    forces=[self.config.max_wheel_force] * len(self._both))
        self._sent = self.speeds
        self.ctx.trace("protective_stop", actuator=self.name, reason=reason)

    def wheel_targets(self, cmd: Twist | WheelSpeeds) -> tuple[float, float]:
        """Wheel speeds (left, right) in rad/s for a command, clipped to ``max_wheel_speed`` (ratio kept)."""
        if isinstance(cmd, Twist):
            half = 0.5 * self.config.track_width * cmd.omega
            left, right = (cmd.v - half) / self.config.wheel_radius, (cmd.v + half) / self.config.wheel_radius
        else:
            left, right = cmd.left, cmd.right
        peak = max(abs(left), abs(right))
        scale = min(1.0, self.config.max_wheel_speed / peak) if peak > 0 else 1.0
        return left * scale, right * scale

    def update(self) -> None:
        """Ramp the wheel speeds towards the targets, push them into the motors and integrate odometry."""
        force = self.config.max_wheel_force
        dt = self.world.time_step * (self.world.tick - self.last_tick) if self.last_tick >= 0 else 0.0
        self.last_tick = self.world.tick
        step = self.config.max_acceleration / self.config.wheel_radius * dt
        speeds = tuple(s + max(-step, min(step, t - s)) for s, t in zip(self.speeds, self.targets, strict=True))
        if speeds != self._sent:  # the motors keep their targets: send only a change, both sides in one call
            self.world.set_joint_motors(
                self.body, self._both, "velocity",
                target_velocities=[speeds[0]] * len(self.left) + [speeds[1]] * len(self.right),
                forces=[force] * len(self._both))
            self._sent = speeds
        self.speeds = speeds
        self._integrate()

    def _integrate(self) -> None:
        """Advance wheel odometry from joint angle deltas, and the travelled distance from the true pose."""
        wheels = self._wheel_angles()
        dl, dr = (wheels[0] - self.last_wheels[0]), (wheels[1] - self.last_wheels[1])
        self.last_wheels = wheels
        r, b = self.config.wheel_radius, self.config.track_width
        ds, dth = r * (dl + dr) / 2.0, r * (dr - dl) / b
        mid = self.odom[2] + dth / 2.0
        x0, y0, yaw0 = self.odom
        self.odom = [x0 + ds * math.cos(mid), y0 + ds * math.sin(mid), wrap_angle(yaw0 + dth)]
        x, y, _ = self.world.pose(self.body)[0]  # the link frame's position (no yaw needed here)
        self.distance += math.hypot(x - self.last_pose[0], y - self.last_pose[1])
        self.last_pose = (x, y)

    def _wheel_means(self, field: int) -> tuple[float, float]:
        """Mean joint state ``field`` (0 = angle, rad; 1 = speed, rad/s) of the left and the right wheels."""
        states: Any = self.world.joint_states(self.body, self._both)
        n = len(self.left)
        left, right = states[:n], states[n:]
        return sum(s[field] for s in left) / n, sum(s[field] for s in right) / len(right)

    def _wheel_angles(self) -> tuple[float, float]:
        return self._wheel_means(0)

    def _wheel_speeds(self) -> tuple[float, float]:
        return self._wheel_means(1)

    def _pose(self) -> tuple[float, float, float]:
        (x, y, _), orn = self.world.pose(self.body)
        yaw = self.world.euler_from_quaternion(orn)[2]
        return float(x), float(y), float(yaw)

    def _contacts(self) -> tuple[str, ...]:
        ignore = set(self.config.ignore_contacts)
        names = set()
        for cp in self.world.contacts(self.body):
            name = self.world.body_name(cp.other) or f"body{cp.other}"
            if name not in ignore:
                names.add(name)
        return tuple(sorted(names))

    def read(self) -> DriveState:
        """Pose, velocity, odometry, distance, wheel speeds and contacts now."""
        x, y, yaw = self._pose()
        lin, ang = self.world.velocity(self.body)
        v = lin[0] * math.cos(yaw) + lin[1] * math.sin(yaw)
        return DriveState(
            pose=(x, y, yaw), v=float(v), omega=float(ang[2]), odometry=(self.odom[0], self.odom[1], self.odom[2]),
            distance=self.distance, wheel_speeds=self._wheel_speeds(), contacts=self._contacts(), command=self.cmd,
        )


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("diff_drive", DiffDrive, DiffDriveConfig)
