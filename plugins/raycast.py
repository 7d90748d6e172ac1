"""Batched ray casts through the World: :func:`RayCaster` makes the world's own caster.

Which rays an engine answers and how (PyBullet: ``rayTestBatch``, with static mesh boxes intersected in numpy to
the same answers; see :mod:`robokit.engines.pybullet.rays`) is the engine's business: a plugin asks the World.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from robokit.engines.interface import RayCaster as RayCasterType
from robokit.engines.interface import RayHits

__all__ = ["RayCaster", "RayCasterType", "RayHits"]


def RayCaster(world: Any, *, skip: Collection[int] = (), mask: int = -1, num_threads: int = 1,  # noqa: N802
              analytic: bool = True) -> RayCasterType:
    """The world's ray caster (:meth:`World.ray_caster <robokit.engines.interface.World.ray_caster>`).

    Args:
        world: The World.
        skip: Body ids the rays never report (hidden from rays first: :meth:`World.hide_from_rays`).
        mask: PyBullet collision-filter mask of the rays (``-1``: every group).
        num_threads: Threads the engine may use per batch.
        analytic: False casts every ray through the engine's own ray test (the reference path).
    """
    return world.ray_caster(skip=skip, mask=mask, num_threads=num_threads, analytic=analytic)  # type: ignore[no-any-return]
