"""The PyBullet engine (``engine = "pybullet"``, the default). Its modules import downwards only.

- :mod:`~robokit.engines.pybullet.world` — :class:`~robokit.engines.pybullet.world.PyBulletWorld`, the World on one
  PyBullet client.
- :mod:`~robokit.engines.pybullet.rays` — its batched ray caster, which knows only the client.

``from robokit.engines.pybullet import PyBulletWorld`` (and the two helpers below) is the public import path.

May import: ``robokit.engines.interface``, ``robokit.errors``, ``robokit.process``; nothing above.
"""

from __future__ import annotations

from robokit.engines.pybullet.world import JOINT_TYPES, PyBulletWorld, to_quaternion

__all__ = ["JOINT_TYPES", "PyBulletWorld", "to_quaternion"]
