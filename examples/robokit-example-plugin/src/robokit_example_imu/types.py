"""The IMU's reading, in a module without pybullet so behaviours can import it."""

from __future__ import annotations

from dataclasses import dataclass

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class ImuReading:
    """One IMU sample, in the frame of the link the IMU is mounted on (x, y, z axes of the URDF link frame).

    Attributes:
        linear_acceleration: Specific force in m/s², as an accelerometer measures it: the link's acceleration
            minus gravity. At rest on the ground it reads about ``+9.81`` along the link axis that points up;
            in free fall it reads about zero.
        angular_velocity: Angular velocity in rad/s, link frame (a gyroscope).
        time: Sim time of the sample, seconds.
    """

    linear_acceleration: Vec3
    angular_velocity: Vec3
    time: float
