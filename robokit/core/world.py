"""The World: the one interface to physics (bodies by name, the sim clock, the run's random generator).

This module is the World's public import path (``from robokit.core.world import World``). The interface itself,
with units and frames, is :mod:`robokit.engines.interface`; the engines are in :mod:`robokit.engines`.
``World(...)`` builds the engine named by ``engine=`` (default PyBullet).
"""

from __future__ import annotations

from robokit.engines.interface import (
    DATA_DIR,
    ChainFrame,
    ChainJoint,
    Contact,
    JointInfo,
    JointState,
    Pose,
    Quat,
    RayHits,
    RenderedImage,
    Vec3,
    World,
    yaw_of,
)
from robokit.engines.pybullet import JOINT_TYPES, to_quaternion

__all__ = [
    "DATA_DIR", "JOINT_TYPES", "ChainFrame", "ChainJoint", "Contact", "JointInfo", "JointState", "Pose", "Quat",
    "RayHits", "RenderedImage", "Vec3", "World", "to_quaternion", "yaw_of",
]
