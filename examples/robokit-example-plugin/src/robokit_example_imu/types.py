"""The IMU's reading: robokit's standard :class:`robokit.msgs.Imu` (frame named, REP 103 signs).

``ImuReading`` is kept as another name for it, so code written against the first version of this example still
imports.
"""

from __future__ import annotations

from robokit.msgs import Imu

ImuReading = Imu
"""The reading type: ``Imu(linear_acceleration, angular_velocity, frame, time)``, vectors in ``frame`` (the
link the IMU is mounted on). At rest ``linear_acceleration`` reads about ``+9.81`` along the link axis that
points up; in free fall about zero."""

__all__ = ["Imu", "ImuReading"]
