"""Commands and readings of the mobile-robot plugins (``diff_drive``, ``lidar``, ``collector``).

Pybullet-free, so behaviours can import them. Units: metres, seconds, radians; world frame unless a name says
otherwise; angles counter-clockwise about +z from +x (ROS REP 103).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Pose2D",
    "wrap_angle",
    "Twist",
    "WheelSpeeds",
    "STOP",
    "DriveState",
    "LaserScan",
    "Collect",
    "CollectorState",
]

Pose2D = tuple[float, float, float]
"""Planar pose ``(x, y, yaw)``: metres, metres, radians, world frame."""


def wrap_angle(a: float) -> float:
    """Wrap an angle to ``[-pi, pi)`` radians."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class Twist:
    """A body-velocity command for ``diff_drive``: ``v`` forward in m/s, ``omega`` yaw rate in rad/s (CCW +)."""

    v: float
    omega: float


@dataclass(frozen=True)
class WheelSpeeds:
    """A raw command for ``diff_drive``: wheel joint speeds in rad/s (positive rolls the robot forward)."""

    left: float
    right: float


STOP = Twist(0.0, 0.0)
"""Stand still (the motors hold the wheels at zero speed)."""


@dataclass(frozen=True)
class DriveState:
    """Reading of ``diff_drive``.

    Attributes:
        pose: Ground-truth base pose ``(x, y, yaw)`` (m, m, rad), world frame (a localisation system's output).
        v: Measured forward speed of the base, m/s (world velocity projected on the heading).
        omega: Measured yaw rate, rad/s.
        odometry: Pose integrated from wheel joint angles alone, ``(x, y, yaw)``, world frame, starting at the
            initial ground-truth pose (drifts with wheel slip, as real odometry does).
        distance: Path length travelled by the base so far, m (from the ground-truth pose at the actuator rate).
        wheel_speeds: Measured mean joint speed per side ``(left, right)``, rad/s.
        contacts: Names of bodies touching the robot now (ground bodies from ``ignore_contacts`` left out).
        command: The command being executed (a :class:`Twist` or :class:`WheelSpeeds`).
    """

    pose: Pose2D
    v: float
    omega: float
    odometry: Pose2D
    distance: float
    wheel_speeds: tuple[float, float]
    contacts: tuple[str, ...] = ()
    command: Twist | WheelSpeeds = STOP


@dataclass(frozen=True)
class LaserScan:
    """Reading of ``lidar``, after ROS ``sensor_msgs/LaserScan``.

    Ray ``i`` points at ``angle_min + i * angle_increment`` (rad, CCW about the sensor's +z from its +x).

    Attributes:
        angle_min: Angle of the first ray, rad.
        angle_max: Angle of the last ray, rad.
        angle_increment: Angle between rays, rad.
        range_min: Rays start this far from the sensor, m (returns closer than that are not seen).
        range_max: Longest range, m.
        ranges: Distance to the first hit per ray, m; ``+inf`` where nothing was hit (REP 117).
        points: Hit points (or ray ends where nothing was hit), world frame, shape ``(n, 3)``, m.
        origin: Sensor position, world frame, m.
        yaw: Sensor heading about world +z, rad.
        stamp: Sim time of the scan, s.
    """

    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray
    points: np.ndarray
    origin: tuple[float, float, float]
    yaw: float
    stamp: float

    @property
    def angles(self) -> np.ndarray:
        """Ray angles in the sensor frame, rad."""
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))

    @property
    def hits(self) -> np.ndarray:
        """Boolean mask of rays that returned."""
        return np.isfinite(self.ranges)


@dataclass(frozen=True)
class Collect:
    """Command of ``collector``: ``armed`` = True to take an object as soon as one is within reach."""

    armed: bool = True


@dataclass(frozen=True)
class CollectorState:
    """Reading of ``collector``.

    Attributes:
        armed: Whether the collector takes objects now.
        count: Objects collected so far.
        last_at: Sim time of the last collection, s (``-1`` if none).
        last_position: Where the last object was taken, world frame ``(x, y)``, m (``None`` if none).
    """

    armed: bool
    count: int
    last_at: float = -1.0
    last_position: tuple[float, float] | None = None
