"""Physics engines behind the World: the interface every engine answers, and the engines themselves.

- :mod:`robokit.engines.interface` — :class:`~robokit.engines.interface.World`, the one interface to physics that
  plugins and behaviours use (abstract methods with units and frames), and its engine-neutral half (names, clock,
  random generator). It imports no engine.
- :mod:`robokit.engines.pybullet` — the PyBullet engine (``engine = "pybullet"``, the default): a package whose
  world sits on its batched ray caster.
- :mod:`robokit.engines.mujoco` — the MuJoCo engine (``engine = "mujoco"``): a package whose world sits on its
  parts (attachments, kinematics, rays, cameras), they on its bodies, and those on the scene's building blocks.

An engine registers here, by name, a function that imports and returns its World class: ``World(engine=NAME)``
builds it, and nothing imports an engine until a World of it is made.

May import: ``robokit.errors``, ``robokit.process`` (below it in the house); nothing above.
"""

from __future__ import annotations

from robokit.engines.interface import World


def _pybullet() -> type[World]:
    from robokit.engines.pybullet.world import PyBulletWorld

    return PyBulletWorld


World.engines["pybullet"] = _pybullet


def _mujoco() -> type[World]:
    import os

    from robokit.extras import require

    os.environ.setdefault("MUJOCO_GL", "egl")  # headless (Mesa's EGL): MuJoCo picks its backend when first imported
    require("mujoco", 'world.engine = "mujoco"')
    from robokit.engines.mujoco.world import MujocoWorld

    return MujocoWorld


World.engines["mujoco"] = _mujoco
