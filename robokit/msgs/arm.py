"""Commands and readings of the arm devices, free of pybullet (behaviours import this module).

Units: metres, radians, seconds, newtons; positions are world frame ``(x, y, z)``; quaternions are PyBullet order
``(x, y, z, w)``.

Actuators and what they take:

- ``joint_control``: :class:`JointCommand` in, :class:`JointStates` out.
- ``ik_arm``: :class:`MoveTo` / :class:`FollowJoints` / :class:`HoldArm` in, :class:`ArmState` out.
- ``gripper``: :class:`GripperCommand` in, :class:`GripperState` out.
- ``contact`` (sensor): :class:`ContactState` out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = [
    "Vec3",
    "Quat",
    "JOINT_MODES",
    "GRIPPER_ACTIONS",
    "JointCommand",
    "JointStates",
    "MoveTo",
    "FollowJoints",
    "HoldArm",
    "ArmState",
    "GripperCommand",
    "open_gripper",
    "close_gripper",
    "GripperState",
    "ContactState",
    "quat_multiply",
    "down_quaternion",
    "quat_angle",
    "cube_grasp_yaw",
    "yaw_of",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

JOINT_MODES = ("position", "velocity", "torque")
GRIPPER_ACTIONS = ("open", "close", "width")


# ----------------------------------------------------------------------------------------- joint_control
@dataclass(frozen=True)
class JointCommand:
    """Drive named joints in one mode.

    Attributes:
        mode: ``position`` (rad or m), ``velocity`` (rad/s or m/s) or ``torque`` (N·m or N).
        values: Joint name -> target in the mode's unit. Joints not named keep their last command.
        max_force: Motor force limit (N·m or N); None = the actuator's configured limit.
        max_velocity: Velocity limit in position mode (rad/s); None = the actuator's configured limit.
    """

    mode: str
    values: Mapping[str, float]
    max_force: float | None = None
    max_velocity: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in JOINT_MODES:
            raise ValueError(f"joint mode must be one of {JOINT_MODES}, got {self.mode!r}")


@dataclass(frozen=True)
class JointStates:
    """Joint states by joint name: position (rad or m), velocity (rad/s or m/s), applied torque (N·m or N).

    ``stopped`` is True once a safety stop (``stop_on`` contact) froze the joints; ``stop_reason`` says why.
    """

    positions: Mapping[str, float]
    velocities: Mapping[str, float]
    torques: Mapping[str, float]
    mode: str = "position"
    stopped: bool = False
    stop_reason: str = ""
    stopped_at: float | None = None


# ----------------------------------------------------------------------------------------- ik_arm
@dataclass(frozen=True)
class MoveTo:
    """Move the end effector to a pose along a straight Cartesian path.

    Attributes:
        position: Target position of the end-effector link, metres, world frame.
        orientation: Target orientation ``(x, y, z, w)``; None = tool pointing down with ``yaw``
            (see :func:`down_quaternion`).
        yaw: Tool yaw about world +z, radians (used when ``orientation`` is None).
        speed: Cartesian speed limit along the path, m/s; None = the actuator's configured speed.
    """

    position: Vec3
    orientation: Quat | None = None
    yaw: float = 0.0
    speed: float | None = None

    def quaternion(self) -> Quat:
        """The target orientation as a quaternion."""
        return self.orientation if self.orientation is not None else down_quaternion(self.yaw)


@dataclass(frozen=True)
class FollowJoints:
    """Move the arm's joints through a path of configurations (a motion planner's answer): from where the arm is to
    each waypoint in turn, straight in joint space, equal time per segment, smooth start and stop.

    Attributes:
        joints: Names of the joints the waypoints give (the arm's joints; others keep their command).
        path: Joint positions per waypoint, in the order of ``joints`` (rad or m).
        speed: End-effector speed limit along the path, m/s; None = the actuator's configured speed.
        joint_speed: Speed limit of every joint along the path, rad/s (or m/s).
    """

    joints: tuple[str, ...]
    path: tuple[tuple[float, ...], ...]
    speed: float | None = None
    joint_speed: float = 1.0


@dataclass(frozen=True)
class HoldArm:
    """Stop where the arm is now (cancels a path)."""


@dataclass(frozen=True)
class ArmState:
    """What the IK arm reports each tick.

    Attributes:
        position: End-effector position, metres, world frame (forward kinematics of the measured joints).
        orientation: End-effector orientation ``(x, y, z, w)``.
        status: ``idle`` (no target yet), ``moving``, ``reached`` or ``failed``.
        reason: Why a target failed (e.g. unreachable, with the residual); empty otherwise.
        target_position: Current goal position (None before the first command).
        target_orientation: Current goal orientation.
        position_error: Distance from the goal, metres (0 with no goal).
        orientation_error: Angle to the goal orientation, radians.
        command_id: Increments with each accepted command (lets a behaviour tell old from new results).
        joint_positions: Measured position of each movable joint, by name (radians or metres).
        path_end: Sim time (seconds) at which the current path's motion ends; None with no path, or from an arm
            that does not plan paths. Until then ``status`` stays ``moving`` unless a new command is sent, so a
            behaviour waiting for ``reached`` may skip reading the arm before this time.
        stopped: A protective stop holds the arm (``status`` is ``failed``, ``reason`` says why): a monitor's
            abort or pre-emption, or the arm's own ``stop_on`` contact sensor.
    """

    position: Vec3
    orientation: Quat
    status: str = "idle"
    reason: str = ""
    target_position: Vec3 | None = None
    target_orientation: Quat | None = None
    position_error: float = 0.0
    orientation_error: float = 0.0
    command_id: int = 0
    joint_positions: Mapping[str, float] = field(default_factory=dict)
    path_end: float | None = None
    stopped: bool = False

    @property
    def reached(self) -> bool:
        """True when the path is done and the pose is within the position and orientation tolerances."""
        return self.status == "reached"

    @property
    def failed(self) -> bool:
        """True when the last target was rejected or could not be tracked."""
        return self.status == "failed"


# ----------------------------------------------------------------------------------------- gripper
@dataclass(frozen=True)
class GripperCommand:
    """Open, close, or go to a width.

    Attributes:
        action: ``open`` (to the open width), ``close`` (squeeze with ``force``) or ``width``.
        width: Target distance between the fingers, metres (``width`` action only).
        force: Finger force limit, newtons; None = the configured force.
    """

    action: str
    width: float | None = None
    force: float | None = None

    def __post_init__(self) -> None:
        if self.action not in GRIPPER_ACTIONS:
            raise ValueError(f"gripper action must be one of {GRIPPER_ACTIONS}, got {self.action!r}")
        if self.action == "width" and self.width is None:
            raise ValueError("a 'width' gripper command needs width (metres)")


def open_gripper() -> GripperCommand:
    """Command: open fully."""
    return GripperCommand("open")


def close_gripper(force: float | None = None) -> GripperCommand:
    """Command: close with a force limit (N)."""
    return GripperCommand("close", force=force)


@dataclass(frozen=True)
class GripperState:
    """What the gripper reports.

    Attributes:
        width: Distance between the fingers, metres.
        target_width: Commanded width, metres.
        action: Last action (``open``, ``close`` or ``width``).
        settled: The fingers have stopped moving (width steady for the settle time; with the gripper's
            ``watch_settling = false``, slower than its settle speed when read).
        holding: Both fingers touch the same body and the width is above the empty-closed width.
        held: Name of the held body (None when not holding).
        finger_contacts: Number of finger contact points with bodies other than the robot.
        stopped: A protective stop froze the fingers (what they hold stays held).
    """

    width: float
    target_width: float
    action: str
    settled: bool
    holding: bool
    held: str | None = None
    finger_contacts: int = 0
    stopped: bool = False


# ----------------------------------------------------------------------------------------- contact
@dataclass(frozen=True)
class ContactState:
    """Contacts of a body (or one of its links) with others.

    Attributes:
        in_contact: At least one contact point.
        points: Number of contact points.
        normal_force: Sum of the normal forces, newtons.
        others: Names of the bodies touched (sorted; unnamed bodies as ``body<id>``).
    """

    in_contact: bool
    points: int = 0
    normal_force: float = 0.0
    others: tuple[str, ...] = ()


# ----------------------------------------------------------------------------------------- maths
def quat_multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a * b`` of ``(x, y, z, w)`` quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def down_quaternion(yaw: float = 0.0) -> Quat:
    """Tool pointing straight down (tool +z along world -z), turned by ``yaw`` radians about world +z.

    Equals PyBullet's ``getQuaternionFromEuler((pi, 0, yaw))``: a gripper with this orientation has its finger
    axis turned by ``yaw`` in the table plane.
    """
    flip: Quat = (1.0, 0.0, 0.0, 0.0)  # rotation by pi about x
    turn: Quat = (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))
    return quat_multiply(turn, flip)


def quat_angle(a: Quat, b: Quat) -> float:
    """Angle between two orientations, radians in [0, pi]."""
    dot = abs(sum(x * y for x, y in zip(a, b, strict=True)))
    return 2.0 * math.acos(min(1.0, dot))


def cube_grasp_yaw(object_yaw: float, current_yaw: float = 0.0) -> float:
    """The yaw among ``object_yaw + k*pi/2`` (a cube is 90° symmetric) closest to ``current_yaw``, radians."""
    k = round((current_yaw - object_yaw) / (math.pi / 2.0))
    return object_yaw + k * math.pi / 2.0


def yaw_of(quaternion: Quat) -> float:
    """Yaw (rotation about +z, radians, in (-pi, pi]) of a quaternion ``(x, y, z, w)``."""
    x, y, z, w = quaternion
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
