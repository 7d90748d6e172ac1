"""Checks made before the first tick that belong to no single component (``robokit validate`` runs them).

Components and behaviours add their own through ``preflight(ctx)`` (see :mod:`robokit.components`); the
Simulation gathers everything in :meth:`robokit.core.simulation.Simulation.preflight`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from robokit.errors import ConfigError

if TYPE_CHECKING:
    from robokit.core.world import World

OVERLAP_TOLERANCE = 0.005
"""Metres of interpenetration two bodies may have at spawn (resting contact is about zero)."""


def is_static(world: World, name: str) -> bool:
    """True for bodies that never move: zero base mass (static primitives, fixed-base URDFs)."""
    return bool(world.mass(name) == 0.0)


def overlapping_bodies(world: World, keys: Mapping[str, str],
                       tolerance: float = OVERLAP_TOLERANCE) -> list[ConfigError]:
    """One problem per pair of bodies that interpenetrate by more than ``tolerance`` metres as spawned.

    Two static bodies may overlap (walls meeting at a corner); a body that moves must not start inside another:
    the solver would throw it out at the first step.
    """
    names = world.body_names
    static = {n: is_static(world, n) for n in names}
    problems = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if static[a] and static[b]:
                continue
            depth = world.penetration(world.body(a), world.body(b))
            if depth > tolerance:
                key = keys.get(b, f"bodies.{b}")
                problems.append(ConfigError(f"{b!r} is spawned overlapping {a!r} ({keys.get(a, a)}) by "
                                            f"{depth * 1000:.0f} mm; move one of them", key=key))
    return problems
