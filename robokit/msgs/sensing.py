"""Force and inertial messages: ``Wrench`` (a force-torque sensor) and ``Imu`` (an inertial measurement unit).

Conventions (ROS REP 103, the ones every robotics stack shares):

- units SI: newtons, newton-metres, metres per second squared, radians per second; right-handed frames;
- every message names its ``frame``: the link whose axes the vectors are expressed in (``"panda_hand"``), or
  ``"world"`` (x forward, y left, z up: gravity is ``(0, 0, -9.81)`` in it);
- orientations are quaternions ``(x, y, z, w)``, the frame's orientation in the world.

Signs, stated once because every author otherwise invents their own:

- a :class:`Wrench` is what the **child link receives from its parent through the measuring joint**, in the
  ``frame`` the message names, torque about that frame's origin. A wrist sensor between a flange (parent) and a hand
  (child) hanging at rest reads ``force ≈ +m·g`` along the frame's axis that points **up** (the flange holds the
  hand up against gravity). When the arm presses the hand down onto a table, the flange pushes the hand down: the
  force turns to point **down**, as large as the press (the table's push on the hand is not measured by the wrist;
  it is what the flange's push works against). A sensor that reports the reverse (what the child exerts on the
  parent) negates both vectors.
- an :class:`Imu`'s ``linear_acceleration`` is the **specific force** an accelerometer measures: the frame's
  acceleration minus gravity. At rest it reads ``+9.81`` m/s² along the axis that points up; in free fall, zero.
  ``angular_velocity`` is the frame's rate of turn, right-hand rule about each axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def _norm(v: Vec3) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@dataclass(frozen=True)
class Wrench:
    """A force and a torque, as a force-torque sensor measures them (see the module's sign convention).

    Attributes:
        force: Newtons, along the axes of ``frame``: what the child link receives from its parent.
        torque: Newton-metres about ``frame``'s origin, same sign convention.
        frame: The frame the vectors are expressed in: a link name, or ``"world"``.
        time: Sim time of the measurement, seconds.
    """

    force: Vec3
    torque: Vec3
    frame: str
    time: float = 0.0

    @property
    def force_norm(self) -> float:
        """Magnitude of the force, newtons (frame-independent)."""
        return _norm(self.force)

    @property
    def torque_norm(self) -> float:
        """Magnitude of the torque, newton-metres."""
        return _norm(self.torque)


@dataclass(frozen=True)
class Imu:
    """One inertial sample (see the module's sign convention).

    Attributes:
        linear_acceleration: Specific force, m/s², along ``frame``'s axes (``+9.81`` up at rest).
        angular_velocity: Rad/s about ``frame``'s axes.
        frame: The frame the vectors are expressed in (the link the IMU is mounted on).
        time: Sim time of the sample, seconds.
        orientation: The frame's orientation in the world ``(x, y, z, w)``, when the IMU reports one (None if
            not: a bare accelerometer and gyroscope).
    """

    linear_acceleration: Vec3
    angular_velocity: Vec3
    frame: str
    time: float = 0.0
    orientation: Quat | None = None
