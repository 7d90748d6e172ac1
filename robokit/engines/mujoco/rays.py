"""Ray casting on the mujoco engine: :class:`MujocoRayCaster` answers the World's ray batches with MuJoCo's own
``mj_multiRay`` (rays from one point, as a lidar casts from outside its robot) or ``mj_ray`` per segment.

Bodies hidden from rays (``MujocoWorld.hide_from_rays``) have their geoms in geom group :data:`HIDDEN_GROUP`, which
a caster made with ``see_hidden=False`` leaves out; collisions do not look at geom groups.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import TYPE_CHECKING

import numpy as np

from robokit.engines.interface import RayHits
from robokit.engines.mujoco.gl import mujoco

if TYPE_CHECKING:
    from robokit.engines.mujoco.bodies import MujocoBodies

HIDDEN_GROUP = 5
"""The geom group of bodies hidden from rays."""


class MujocoRayCaster:
    """Casts batches of segments in one MuJoCo world (see :class:`robokit.engines.interface.RayCaster`)."""

    def __init__(self, world: MujocoBodies, skip: Collection[int], see_hidden: bool) -> None:
        self.world = world
        self.skip = set(skip)
        self.groups = np.ones(6, dtype=np.uint8)
        if not see_hidden:
            self.groups[HIDDEN_GROUP] = 0
        self.rays_cast = 0
        self.rays_total = 0
        self._starts = np.zeros((3, 0))

    def refresh(self) -> None:
        """Compile the scene if bodies were added or removed (MuJoCo's rays read the current state)."""
        self.world.compiled()

    def starts(self, n: int) -> np.ndarray:
        """The caster's own (3, n) buffer of segment starts that :meth:`cast_lean` reads."""
        if self._starts.shape[1] != n:
            self._starts = np.zeros((3, n))
        return self._starts

    def _fractions(self, starts: np.ndarray, ends: np.ndarray, normals: np.ndarray | None) -> tuple[
            np.ndarray, np.ndarray]:
        """Per segment (arrays (N, 3)): the hit geom (-1: none) and the fraction along it (1.0: none)."""
        m, d = self.world.compiled()
        n = len(starts)
        vec = np.ascontiguousarray(ends - starts)
        geom = np.full(n, -1, dtype=np.int32)
        dist = np.full(n, -1.0)
        if n and normals is None and np.all(starts == starts[0]):
            mujoco.mj_multiRay(m, d, np.ascontiguousarray(starts[0]), vec.reshape(-1), self.groups, True, -1, geom,
                               dist, None, n, mujoco.mjMAXVAL)
        else:
            one, normal = np.zeros(1, dtype=np.int32), np.zeros(3)
            for i in range(n):
                dist[i] = mujoco.mj_ray(m, d, np.ascontiguousarray(starts[i]), vec[i], self.groups, True, -1, one,
                                        normal)
                geom[i] = one[0]
                if normals is not None:
                    normals[i] = normal
        missed = (dist < 0.0) | (dist > 1.0) | (geom < 0)
        geom[missed] = -1
        return geom, np.where(missed, 1.0, dist)

    def _owners(self, geom: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Robokit body id and link per hit geom (-1, -1 for none and for skipped bodies)."""
        m = self.world.model
        owner = self.world.owners()
        body, link = np.full(len(geom), -1, dtype=int), np.full(len(geom), -1, dtype=int)
        for i, g in enumerate(geom.tolist()):
            if g >= 0:
                rid, lnk = owner.get(int(m.geom_bodyid[g]), (-1, -1))
                if rid not in self.skip:
                    body[i], link[i] = rid, lnk
        return body, link

    def cast(self, starts: np.ndarray, ends: np.ndarray, *, detail: bool = True) -> RayHits:
        """Answers for the segments ``starts[i] -> ends[i]`` (arrays (N, 3), world frame, m)."""
        starts, ends = np.asarray(starts, float), np.asarray(ends, float)
        normal = np.zeros((len(starts), 3)) if detail else None
        geom, frac = self._fractions(starts, ends, normal)
        body, link = self._owners(geom)
        frac = np.where(body >= 0, frac, 1.0)
        self.rays_cast += len(starts)
        self.rays_total += len(starts)
        position = None
        if detail and normal is not None:
            position = np.where((body >= 0)[:, None], starts + (ends - starts) * frac[:, None], 0.0)
            normal[body < 0] = 0.0
        return RayHits(body, link, frac, position, normal, np.ones(len(starts), dtype=bool))

    def cast_lean(self, ends: np.ndarray, inv_len: np.ndarray, *, ignore: int = -2,
                  refresh: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Hit body (-1: none) and fraction per segment from :meth:`starts` to ``ends`` (3, N); a hit on body
        ``ignore`` counts as none."""
        geom, frac = self._fractions(self._starts.T, np.asarray(ends, float).T, None)
        body, _ = self._owners(geom)
        body[body == ignore] = -1
        self.rays_cast += len(frac)
        self.rays_total += len(frac)
        return body, np.where(body >= 0, frac, 1.0)
