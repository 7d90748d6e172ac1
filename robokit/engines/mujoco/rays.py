"""Ray casting on the mujoco engine: :class:`MujocoRayCaster` answers the World's ray batches with MuJoCo's own
``mj_multiRay`` (rays from one point, as a lidar casts from outside its robot) or ``mj_ray`` per segment.

Bodies hidden from rays (``MujocoWorld.hide_from_rays``) have their geoms in geom group :data:`HIDDEN_GROUP`, which
a caster made with ``see_hidden=False`` leaves out; collisions do not look at geom groups.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.engines.interface import RayHits
from robokit.engines.mujoco.gl import mujoco

if TYPE_CHECKING:
    from robokit.engines.mujoco.bodies import MujocoBodies

HIDDEN_GROUP = 5
"""The geom group of bodies hidden from rays."""
ZERO_LENGTH = 1e-12
"""Segments shorter than this (m) hit nothing."""
GRAZING = 1e-9
"""A hit whose surface normal is within this cosine of perpendicular to the ray is grazing, not entering."""
NUDGE = 1e-7
"""How far (m) beyond a second surface it leaves a continued ray starts."""
MAX_PASSES = 8
"""Surfaces one ray may pass through (leaving or grazing) before it counts as a miss."""


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
        """Per segment (arrays (N, 3)): the hit geom (-1: none) and the fraction along it (1.0: none), by the
        World's rule (:class:`~robokit.engines.interface.RayCaster`): a surface the ray leaves (it started inside
        the shape) or only grazes is passed through, a surface at the very end is not a hit, and a zero-length
        segment hits nothing."""
        m, d = self.world.compiled()
        n = len(starts)
        vec = np.ascontiguousarray(ends - starts)
        length = np.sqrt(np.einsum("ij,ij->i", vec, vec))
        empty = length < ZERO_LENGTH
        if empty.any():  # MuJoCo refuses a zero vector (a fatal error): give those a unit one and drop the answer
            vec[empty] = (0.0, 0.0, 1.0)
        geom = np.full(n, -1, dtype=np.int32)
        dist = np.full(n, -1.0)
        normal = normals if normals is not None else np.zeros((n, 3))
        if n and np.all(starts == starts[0]):
            mujoco.mj_multiRay(m, d, np.ascontiguousarray(starts[0]), vec.reshape(-1), self.groups, True, -1, geom,
                               dist, normal.reshape(-1) if normal.flags.c_contiguous else None, n,
                               mujoco.mjMAXVAL)
        else:
            one, out = np.zeros(1, dtype=np.int32), np.zeros(3)
            for i in range(n):
                dist[i] = mujoco.mj_ray(m, d, np.ascontiguousarray(starts[i]), vec[i], self.groups, True, -1, one,
                                        out)
                geom[i], normal[i] = one[0], out
        hit = (dist >= 0.0) & (geom >= 0)
        leaving = hit & (np.einsum("ij,ij->i", normal, vec) >= -GRAZING * length)
        for i in np.flatnonzero(leaving & ~empty).tolist():
            geom[i], dist[i] = self._onwards(m, d, starts[i], vec[i], int(geom[i]), float(length[i]),
                                             normal[i])
        missed = (dist < 0.0) | (dist >= 1.0) | (geom < 0) | empty
        geom[missed] = -1
        if normals is not None:
            normals[missed] = 0.0
        return geom, np.where(missed, 1.0, dist)

    def _onwards(self, m: Any, d: Any, start: np.ndarray, vec: np.ndarray, geom: int, length: float,
                 normal: np.ndarray) -> tuple[int, float]:
        """Continue a ray that leaves (or grazes) ``geom``: cast again from the start with the geom's
        MuJoCo body left out, so a surface inside that shape still counts; past a second such surface, from just
        beyond it. Returns the next surface entered (geom, fraction of the whole segment; -1 and -1.0: none before
        the end); ``normal`` receives its normal."""
        one, out = np.zeros(1, dtype=np.int32), np.zeros(3)
        origin, exclude = 0.0, int(m.geom_bodyid[geom])
        for _ in range(MAX_PASSES):
            rest = vec * (1.0 - origin)
            step = mujoco.mj_ray(m, d, np.ascontiguousarray(start + vec * origin), np.ascontiguousarray(rest),
                                 self.groups, True, exclude, one, out)
            if step < 0.0 or one[0] < 0:
                return -1, -1.0
            frac = origin + step * (1.0 - origin)
            if float(out @ vec) < -GRAZING * length:
                normal[:] = out
                return int(one[0]), frac
            origin, exclude = frac + NUDGE / length, int(m.geom_bodyid[one[0]])
            if origin >= 1.0:
                return -1, -1.0
        return -1, -1.0

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
