"""Message types: what sensors hand behaviours and what behaviours hand actuators.

They live in robokit itself (as ROS keeps them in ``sensor_msgs`` / ``geometry_msgs``, not in the drivers), so a
third-party sensor, actuator or behaviour imports only :mod:`robokit`. None of these modules imports pybullet or
OpenCV; :mod:`robokit.msgs.vision` and :mod:`robokit.msgs.mobile` use numpy.

- :mod:`robokit.msgs.arm` — ``JointCommand``/``JointStates`` (``joint_control``), ``MoveTo``/``HoldArm``/``ArmState``
  (``ik_arm``), ``GripperCommand``/``GripperState`` (``gripper``), ``ContactState`` (``contact``), quaternion helpers.
- :mod:`robokit.msgs.vision` — ``CameraFrame`` (``camera``), ``Detection``/``Detections`` (``colour_detector``),
  ``deproject``.
- :mod:`robokit.msgs.mobile` — ``Twist``/``WheelSpeeds``/``DriveState`` (``diff_drive``), ``LaserScan`` (``lidar``),
  ``Collect``/``CollectorState`` (``collector``), ``Pose2D``, ``wrap_angle``.
- :mod:`robokit.msgs.keyboard` — ``KeyState`` (``keyboard``).
- :mod:`robokit.msgs.body` — ``BodyState`` (``body_pose``: a dict of body name -> ``BodyState``).
- :mod:`robokit.msgs.control` — ``EEDelta``/``EEState`` (``ee_delta``), ``PidState`` (``pid``).
- :mod:`robokit.msgs.sensing` — ``Wrench`` (``force_torque``), ``Imu``: frames named in the message, REP 103 signs.

Every name is also importable from here: ``from robokit.msgs import Twist, LaserScan``.
"""

from __future__ import annotations

from robokit.msgs.arm import (
    GRIPPER_ACTIONS,
    JOINT_MODES,
    ArmState,
    ContactState,
    FollowJoints,
    GripperCommand,
    GripperState,
    HoldArm,
    JointCommand,
    JointStates,
    MoveTo,
    Quat,
    Vec3,
    close_gripper,
    cube_grasp_yaw,
    down_quaternion,
    open_gripper,
    quat_angle,
    quat_multiply,
    yaw_of,
)
from robokit.msgs.body import BodyState
from robokit.msgs.control import EEDelta, EEState, PidState
from robokit.msgs.keyboard import KeyState
from robokit.msgs.mobile import (
    STOP,
    Collect,
    CollectorState,
    DriveState,
    LaserScan,
    Pose2D,
    Twist,
    WheelSpeeds,
    wrap_angle,
)
from robokit.msgs.sensing import Imu, Wrench
from robokit.msgs.vision import CameraFrame, Detection, Detections, Matrix16, deproject, gl_matrix

__all__ = [
    "GRIPPER_ACTIONS", "JOINT_MODES", "STOP",
    "EEDelta", "EEState", "PidState",
    "ArmState", "BodyState", "CameraFrame", "Collect", "CollectorState", "ContactState", "Detection", "Detections",
    "DriveState", "FollowJoints", "Imu", "Wrench",
    "GripperCommand", "GripperState", "HoldArm", "JointCommand", "JointStates", "KeyState", "LaserScan", "Matrix16",
    "MoveTo", "Pose2D", "Quat", "Twist", "Vec3", "WheelSpeeds",
    "close_gripper", "cube_grasp_yaw", "deproject", "down_quaternion", "gl_matrix", "open_gripper", "quat_angle",
    "quat_multiply", "wrap_angle", "yaw_of",
]
