"""Messages of the learning-oriented arm devices: ``ee_delta`` (end-effector steps) and ``pid`` (joint PID).

Units: metres, radians, seconds, N·m; positions world frame ``(x, y, z)``; quaternions ``(x, y, z, w)``.
``pid`` takes :class:`robokit.msgs.arm.JointCommand` in ``position`` mode as its setpoints.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

__all__ = ["EEDelta", "EEState", "PidState"]


@dataclass(frozen=True)
class EEDelta:
    """Move the end effector by ``delta`` metres (world frame ``(dx, dy, dz)``) from where it is now."""

    delta: Vec3


@dataclass(frozen=True)
class EEState:
    """End-effector position (m) and linear velocity (m/s), world frame; orientation ``(x, y, z, w)``; the arm's
    joint positions by name (rad)."""

    position: Vec3
    velocity: Vec3
    orientation: Quat
    joint_positions: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class PidState:
    """Per joint, by name: setpoint and position (rad), velocity (rad/s), applied torque and its P, I, D terms
    (N·m), and whether the output hit ``max_torque``."""

    setpoints: Mapping[str, float]
    positions: Mapping[str, float]
    velocities: Mapping[str, float]
    torques: Mapping[str, float]
    p_terms: Mapping[str, float]
    i_terms: Mapping[str, float]
    d_terms: Mapping[str, float]
    saturated: Mapping[str, bool]
