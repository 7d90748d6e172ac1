"""The mujoco engine (``engine = "mujoco"``): the World on one MuJoCo model. Its modules import downwards only.

- :mod:`~robokit.engines.mujoco.world` — :class:`~robokit.engines.mujoco.world.MujocoWorld`, the World itself:
  stepping, motors, wrenches and contacts, and the door to the parts below.
- the parts it is made of, each knowing only the bodies' half below it: :mod:`~robokit.engines.mujoco.attach`
  (welds and joint couplings), :mod:`~robokit.engines.mujoco.kin` (chains and Jacobians),
  :mod:`~robokit.engines.mujoco.rays` (the ray caster), :mod:`~robokit.engines.mujoco.render` (cameras).
- :mod:`~robokit.engines.mujoco.bodies` — :class:`~robokit.engines.mujoco.bodies.MujocoBodies`, the bodies' half
  (building the scene, compiling it, poses), on :mod:`~robokit.engines.mujoco.extras` (the World's engine-neutral
  helpers).
- the scene's building blocks: :mod:`~robokit.engines.mujoco.scene` and :mod:`~robokit.engines.mujoco.mjcf` (MjSpec
  bodies from primitives, URDF and MJCF), :mod:`~robokit.engines.mujoco.links` (joint tables and motor gains),
  :mod:`~robokit.engines.mujoco.spatial` (poses and quaternions), :mod:`~robokit.engines.mujoco.support` (what the
  engine refuses), :mod:`~robokit.engines.mujoco.gl` (MuJoCo, imported headless).

This package's ``__init__`` imports nothing: ``robokit.engines`` imports :mod:`~robokit.engines.mujoco.world` when
a World of this engine is made.

May import: ``robokit.engines.interface``, ``robokit.errors``; nothing above.
"""
