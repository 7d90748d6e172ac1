"""Reading of the ``body_pose`` sensor (ground truth), free of pybullet."""

from __future__ import annotations

from typing import NamedTuple

__all__ = [
    "BodyState",
]


class BodyState(NamedTuple):
    """Pose and velocity of one body's base: metres, ``(x, y, z, w)`` quaternion, m/s and rad/s, world frame."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    linear_velocity: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]
