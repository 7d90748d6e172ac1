"""Batched ray casts that give ``rayTestBatch``'s answers while PyBullet casts only the rays that need it.

A lidar scan is mostly PyBullet's C ray test, whose cost is per ray (nearly independent of ray length). In a mapped
scene most rays end on the static map: walls and obstacles that never move. :class:`PyBulletRayCaster` intersects
the rays with the static boxes robokit builds as triangle meshes (``collision = "mesh"``) in numpy — for those
PyBullet's ray test is exact ray-triangle arithmetic, which numpy reproduces to ~1e-14 m — and hands to
``rayTestBatch`` only the rays that may meet anything else before their static hit: every other body's bounding box
(``getAABB``, per link, read at each cast) is tested against each ray segment, and a ray that crosses one is cast
by PyBullet in full. Rays whose analytic answer is borderline (grazing a box's edge within Bullet's triangle
tolerance, starting inside or next to a box, two boxes hit at the same distance, a hit near the segment's end) are
cast by PyBullet too. So every answer is PyBullet's own or equal to it within float rounding (about 1e-15 of the
ray's length). In a scene without such boxes every ray is cast by PyBullet, as before.

Not intersected in numpy (cast through PyBullet whenever a ray crosses their bounding box): bodies that can move,
convex primitives (PyBullet's ray test against a convex box, cylinder or sphere is iterative, off by up to ~2 mm,
~1 cm for cylinders and spheres: numpy would be *more* exact, hence different), URDF meshes, anything with joints.
A static mesh box is checked once with PyBullet (a probe ray must hit it: its collision group is not masked out)
and its pose re-read at each cast (a body moved by ``resetBasePositionAndOrientation`` is followed).

A triangle mesh has no inside: PyBullet answers a ray that starts inside a mesh box with the face it leaves by.
By the World's rule (:class:`~robokit.engines.interface.RayCaster`) that face is no hit: such a ray is cast on from
just beyond it (the answer was the nearest surface, so nothing lies before it) until it enters a surface.

PyBullet's ray test against a convex primitive it starts inside answers with a hit at fraction 0 whenever the ray
heads inwards: a sphere or capsule nearly always, a box or cylinder on rare rays (one seen: along a world axis, 5 mm
inside a face). A hit at fraction 0 whose shape holds the start (by the shape's own geometry,
``getCollisionShapeData``) is cast again asking PyBullet for every surface along the segment (``reportHitNumber``:
one hit per shape, in no promised order), and the nearest one whose shape does not hold the start is the answer: a
surface of another body inside the shape still counts.

A zero-length segment hits nothing (body -1, fraction 1.0) and is not cast.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import numpy as np

from robokit.engines.interface import RayHits

GEOM_MESH = 5
EDGE_TOLERANCE = 2e-4
"""Bullet accepts a triangle hit up to ``1e-4 * |n|^2`` outside an edge (n = the triangle's edge cross product):
for a box face ``a x b`` that is ``1e-4 * b`` m beyond an edge of length ``a``. Rays within twice that (per box,
of its longest edge) of a box edge are cast by PyBullet."""
_TINY = 1e-300
"""Added to ray components in box frames: 0 becomes it, any component above ~1e-284 is unchanged."""
AABB_PAD = 1e-3
"""m added around PyBullet's bounding boxes before testing rays against them (they already include its margins)."""
NUDGE = 1e-7
"""How far (m) beyond a mesh box's face a ray that started inside the box is cast on."""
MAX_PASSES = 8
"""Mesh boxes one ray may start inside of, one after the other, before it counts as a miss."""
INSIDE = 1e-9
"""m within a shape's surface a point must lie to be inside it (a start on a face is outside)."""
ZERO_LENGTH = 1e-12
"""Segments shorter than this (m) hit nothing."""
GEOM_SPHERE, GEOM_BOX, GEOM_CYLINDER, GEOM_CAPSULE = 2, 3, 4, 7
MAX_HITS = 16
"""Surfaces along one ray read back when it starts inside a convex primitive, before the rest count as none."""
START_HIT = 1e-9
"""A hit at a fraction below this is checked against the shape holding the segment's start."""
_NO_HIT = (-1, -1, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


class PyBulletRayCaster:
    """``rayTestBatch`` for a PyBullet world (the :class:`~robokit.engines.interface.RayCaster` of
    :meth:`PyBulletWorld.ray_caster <robokit.engines.pybullet.PyBulletWorld.ray_caster>`), with the static mesh
    boxes intersected in numpy (see the module doc).

    Args:
        world: A PyBulletWorld (its client, and its ``mesh_boxes``).
        skip: Body ids the rays can never hit (the caller puts them in a collision group the mask leaves out);
            they are neither intersected nor bounding-box tested.
        mask: ``collisionFilterMask`` passed to ``rayTestBatch``.
        num_threads: ``numThreads`` passed to ``rayTestBatch``.
        analytic: False casts every ray through PyBullet (the reference path).
    """

    def __init__(self, world: Any, *, skip: Collection[int] = (), mask: int = -1, num_threads: int = 1,
                 analytic: bool = True) -> None:
        self.world = world
        self.client = world.client
        self.skip = set(skip)
        self.mask = mask
        self.num_threads = num_threads
        self.analytic = analytic
        self._signature: tuple[int, int] | None = None
        self._boxes: list[int] = []  # body ids intersected in numpy
        self._half = np.zeros((0, 3))
        self._tol = np.zeros(0)
        self._poses: list[Any] = []
        self._centre = np.zeros((0, 3))
        self._rot = np.zeros((0, 3, 3))
        self._others: list[tuple[int, int]] = []  # (body, link) tested by bounding box
        self._solids: dict[tuple[int, int], list[tuple[int, tuple, Any, Any]]] = {}
        """(body, link) -> its convex primitives: (geometry type, dimensions, position and orientation in the
        link's centre-of-mass frame), from ``getCollisionShapeData``."""
        # one slab test covers the boxes (rows 0..B-1) and the others' bounding boxes (rows B..B+K-1, world axes):
        # frame[i, r] = (row r's axis i in the world, -(axis i . centre)); grown[i, r] = half extent tested along it
        self._frame = np.zeros((3, 0, 4))
        self._grown = np.zeros((3, 0))
        self._box_table = np.zeros((5, 0))
        self._cols = np.zeros(0, dtype=int)
        self._checks = np.zeros((5, 0), dtype=bool)
        self._starts_h = np.ones((4, 0))  # starts as homogeneous columns (x, y, z, 1), reused between casts
        self._grown_full = np.zeros((3, 0, 0))  # self._grown repeated for each ray, (3, R, N)
        self._work = np.zeros((3, 3, 0, 0))
        self._fresh: tuple[np.ndarray, ...] = ()  # per ray: no hit body, link, fraction; not cast (copied per cast)
        self.rays_cast = 0
        """Rays PyBullet cast so far (for benchmarks and tests)."""
        self.rays_total = 0

    # ----------------------------------------------------------------- scene
    def _classify(self) -> None:
        """Sort the world's bodies into numpy-intersected mesh boxes and bounding-box-tested others."""
        c = self.client
        boxes: list[int] = []
        others: list[tuple[int, int]] = []
        self._solids = {}
        for i in range(c.getNumBodies()):
            body = c.getBodyUniqueId(i)
            if body in self.skip:
                continue
            for link in range(-1, c.getNumJoints(body)):
                shapes = [(int(d[2]), tuple(d[3]), d[5], d[6]) for d in c.getCollisionShapeData(body, link)
                          if d[2] in (GEOM_SPHERE, GEOM_BOX, GEOM_CYLINDER, GEOM_CAPSULE)]
                if shapes:
                    self._solids[(body, link)] = shapes
            if self.analytic and self._is_static_mesh_box(body):
                boxes.append(body)
            else:
                others.extend((body, link) for link in range(-1, c.getNumJoints(body)))
        self._boxes = self._probe(boxes)
        others.extend((body, -1) for body in boxes if body not in self._boxes)
        self._others = others
        nb, rows = len(self._boxes), len(self._boxes) + len(others)
        self._half = np.array([self.world.mesh_boxes[b] for b in self._boxes], float).reshape(-1, 3)
        self._tol = EDGE_TOLERANCE * 2.0 * self._half.max(axis=1, initial=0.0) + 1e-6
        self._grown = np.zeros((3, rows))
        self._grown[:, :nb] = (self._half + self._tol[:, None]).T
        self._frame = np.zeros((3, rows, 4))
        self._grown_full = np.zeros((3, 0, 0))
        self._frame[:, nb:, :3] = np.eye(3)[:, None, :]  # the others' rows: world axes (centres set per cast)
        self._poses = [None] * nb
        # per box: tolerance, half extents, body id (one take gives the named box's)
        self._box_table = np.vstack([self._tol, self._half.T, self._boxes]).reshape(5, nb)
        self._centre = np.zeros((nb, 3))
        self._rot = np.zeros((nb, 3, 3))

    def _is_static_mesh_box(self, body: int) -> bool:
        c = self.client
        if body not in self.world.mesh_boxes or c.getNumJoints(body) != 0 or c.getDynamicsInfo(body, -1)[0] != 0:
            return False
        shapes = c.getCollisionShapeData(body, -1)
        if len(shapes) != 1:
            return False
        _, _, geom, scale, _, pos, orn = shapes[0]
        return bool(geom == GEOM_MESH and tuple(scale) == (1.0, 1.0, 1.0) and tuple(pos) == (0.0, 0.0, 0.0)
                    and tuple(orn) == (0.0, 0.0, 0.0, 1.0))

    def _probe(self, boxes: list[int]) -> list[int]:
        """The boxes PyBullet's rays do hit: one short probe ray onto each face centre, from just outside it (a box
        whose collision group the mask leaves out, or buried on every side, stays with PyBullet)."""
        if not boxes:
            return []
        c = self.client
        starts, ends = [], []
        for body in boxes:
            pos, orn = c.getBasePositionAndOrientation(body)
            rot = np.asarray(c.getMatrixFromQuaternion(orn), float).reshape(3, 3)
            half = np.asarray(self.world.mesh_boxes[body], float)
            for axis in range(3):
                for sign in (-1.0, 1.0):
                    n = rot[:, axis] * sign
                    face = np.asarray(pos) + n * half[axis]
                    starts.append(face + n * 1e-3)
                    ends.append(face - n * 1e-3)
        hits = c.rayTestBatch(starts, ends, numThreads=1, collisionFilterMask=self.mask)
        return [body for k, body in enumerate(boxes) if any(h[0] == body for h in hits[6 * k:6 * k + 6])]

    def refresh(self) -> None:
        """Re-read the scene (see :meth:`cast_lean`); :meth:`cast` does it itself."""
        self._refresh()

    def _refresh(self) -> None:
        """Re-sort the bodies if any were added or removed; re-read the boxes' poses and the others' bounding
        boxes (padded by ``AABB_PAD``)."""
        c = self.client
        signature = (c.getNumBodies(), self.world.removals)
        if signature != self._signature:
            self._classify()
            self._signature = signature
        pose = c.getBasePositionAndOrientation
        poses = [pose(body) for body in self._boxes]
        nb = len(self._boxes)
        if poses != self._poses:
            for k, p in enumerate(poses):
                if p != self._poses[k]:
                    self._centre[k] = p[0]
                    self._rot[k] = np.asarray(c.getMatrixFromQuaternion(p[1]), float).reshape(3, 3)
            self._poses = poses
            axes = self._rot.transpose(2, 0, 1)  # (3, B, 3): axes[i, b] = box b's axis i in the world
            self._frame[:, :nb, :3] = axes
            self._frame[:, :nb, 3] = -np.einsum("ibj,bj->ib", axes, self._centre)
        if self._others and nb:  # (without boxes every ray is cast: no test)
            aabb = c.getAABB
            boxes = [aabb(b, link) for b, link in self._others]
            # (a few floats per box: plain Python costs less than numpy's per-call overhead here)
            self._frame[:, nb:, 3] = [[(lo[i] + hi[i]) * -0.5 for lo, hi in boxes] for i in range(3)]
            self._grown[:, nb:] = [[(hi[i] - lo[i]) * 0.5 + AABB_PAD for lo, hi in boxes] for i in range(3)]

    # ----------------------------------------------------------------- casting
    def cast(self, starts: np.ndarray, ends: np.ndarray, *, detail: bool = True) -> RayHits:
        """Answers for the segments ``starts[i] -> ends[i]`` (arrays ``(N, 3)``, world frame).

        ``detail=False`` leaves out hit positions and normals (``None``): a lidar needs only bodies and fractions.
        """
        starts = np.asarray(starts, float)
        ends = np.asarray(ends, float)
        n = len(starts)
        self._refresh()
        body, frac, cast = (a.copy() for a in self._blank(n))
        pos = np.zeros((n, 3)) if detail else None
        normal = np.zeros((n, 3)) if detail else None
        vec = ends - starts
        length = np.sqrt(np.einsum("ij,ij->i", vec, vec))
        empty = length < ZERO_LENGTH
        if self.analytic and self._boxes:  # without mesh boxes the bounding-box test alone rarely pays
            # axis-first (3, N) layouts: numpy's per-axis work is then on contiguous rows
            s_t = self.starts(n)
            s_t[:] = starts.T
            d_t = np.ascontiguousarray(vec.T)
            inv_len = 1.0 / np.where(empty, 1.0, length)
            need = self._intersect(d_t, inv_len, body, frac, pos, normal)
        else:
            need = np.ones(n, dtype=bool)
        if empty.any():  # a zero-length segment hits nothing, whatever the slab test or PyBullet would say
            need &= ~empty
            body[empty], frac[empty] = -1, 1.0
            if pos is not None and normal is not None:
                pos[empty] = normal[empty] = 0.0
        idx = need.nonzero()[0]
        link = self._fresh[0].copy()
        if len(idx):
            results = self.client.rayTestBatch(starts[idx], ends[idx], numThreads=self.num_threads,
                                               collisionFilterMask=self.mask)
            if self.world.mesh_boxes:
                results = self._beyond_mesh_exits(starts[idx], ends[idx], results)
            if self._solids:
                results = self._beyond_solid_starts(starts[idx], ends[idx], results)
            m = len(results)
            body[idx] = np.fromiter((r[0] for r in results), dtype=int, count=m)
            frac[idx] = np.fromiter((r[2] for r in results), dtype=float, count=m)
            link[idx] = np.fromiter((r[1] for r in results), dtype=int, count=m)
            if pos is not None and normal is not None:
                pos[idx] = [r[3] for r in results]
                normal[idx] = [r[4] for r in results]
            cast[idx] = True
        self.rays_cast += len(idx)
        self.rays_total += n
        return RayHits(body, link, frac, pos, normal, cast)

    def _blank(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Answers of ``n`` rays that hit nothing, not cast (body ``-1``, fraction 1, flag False): kept, to copy."""
        if len(self._fresh) == 0 or len(self._fresh[0]) != n:
            self._fresh = (np.full(n, -1, dtype=int), np.ones(n), np.zeros(n, dtype=bool))
        return self._fresh  # type: ignore[return-value]

    def starts(self, n: int) -> np.ndarray:
        """The segment starts :meth:`cast_lean` reads: a (3, n) array (world frame, m, one row per axis) for the
        caller to fill in place (it is the caster's own buffer: no copy per cast)."""
        if self._starts_h.shape[1] != n:
            self._starts_h = np.ones((4, n))
        return self._starts_h[:3]

    def cast_lean(self, ends: np.ndarray, inv_len: np.ndarray, *, ignore: int = -2,
                  refresh: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Hit body (``-1``: none) and fraction per segment, from :meth:`starts` to ``ends`` (3, N), given
        ``1 / length`` of each segment: :meth:`cast` with ``detail=False`` for a sensor that scans every few ticks,
        in fewer steps (no link, no per-ray flags; a hit on body ``ignore`` counts as none). ``refresh=False``:
        the caller called :meth:`refresh` just before (nothing moved since)."""
        s_t = self._starts_h[:3]
        n = s_t.shape[1]
        if refresh:
            self._refresh()
        fresh = self._blank(n)
        body, frac = fresh[0].copy(), fresh[1].copy()
        empty = ~(inv_len < 1.0 / ZERO_LENGTH)  # zero length (1 / 0 is inf): no hit
        if self.analytic and self._boxes:
            need = self._intersect(np.subtract(ends, s_t), inv_len, body, frac, None, None)
        else:
            need = np.ones(n, dtype=bool)
        if empty.any():
            need &= ~empty
            body[empty], frac[empty] = -1, 1.0
        idx = need.nonzero()[0]
        if len(idx):
            results = self.client.rayTestBatch(s_t.T[idx], ends.T[idx], numThreads=self.num_threads,
                                               collisionFilterMask=self.mask)
            if self.world.mesh_boxes:
                results = self._beyond_mesh_exits(s_t.T[idx], ends.T[idx], results)
            if self._solids:
                results = self._beyond_solid_starts(s_t.T[idx], ends.T[idx], results)
            for k, r in zip(idx.tolist(), results, strict=True):  # (a few rays: plain Python)
                body[k], frac[k] = (r[0], r[2]) if r[0] != ignore else (-1, 1.0)
        if ignore in self._boxes:  # a mesh box intersected here counts as none too
            frac[body == ignore] = 1.0
            body[body == ignore] = -1
        self.rays_cast += len(idx)
        self.rays_total += n
        return body, frac

    def _beyond_mesh_exits(self, starts: np.ndarray, ends: np.ndarray, results: Any) -> Any:
        """``rayTestBatch``'s ``results`` for the segments ``starts[k] -> ends[k]`` ((n, 3)), each answer that is
        the face of a mesh box the segment starts inside (the face it leaves by) replaced by what the segment
        enters beyond it (see the module doc)."""
        boxes = self.world.mesh_boxes
        frames: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

        def inside(body: int, point: np.ndarray) -> bool:
            if body not in boxes:
                return False
            if body not in frames:
                pos, orn = self.client.getBasePositionAndOrientation(body)
                rot = np.asarray(self.client.getMatrixFromQuaternion(orn), float).reshape(3, 3)
                frames[body] = (np.asarray(pos, float), rot, np.asarray(boxes[body], float) - INSIDE)
            pos, rot, half = frames[body]
            return bool((np.abs((point - pos) @ rot) < half).all())

        out = None
        for k, r in enumerate(results):
            if r[0] not in boxes or not inside(r[0], starts[k]):
                continue
            out = list(results) if out is None else out
            start, end = starts[k], ends[k]
            vec = end - start
            nudge = NUDGE / float(np.sqrt(vec @ vec))
            origin, hit = 0.0, r
            answer = (-1, -1, 1.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
            for _ in range(MAX_PASSES):
                origin += hit[2] * (1.0 - origin) + nudge  # just beyond the face left, as a fraction of the segment
                if origin >= 1.0:
                    break
                point = start + vec * origin
                (hit,) = self.client.rayTestBatch([point], [end], numThreads=1, collisionFilterMask=self.mask)
                if hit[0] < 0:
                    break
                if not inside(hit[0], point):
                    answer = (hit[0], hit[1], origin + hit[2] * (1.0 - origin), hit[3], hit[4])
                    break
            out[k] = answer
        return results if out is None else out

    def _placed(self, body: int, link: int, frames: dict[tuple[int, int], list[Any]]) -> list[Any]:
        """The convex primitives of ``body``'s ``link`` (a mesh box counts as a box) in the world: (geometry type,
        dimensions, centre, world-from-shape rotation) each; looked up once per cast in ``frames``."""
        key = (body, link)
        if key in frames:
            return frames[key]
        c = self.client
        placed = []
        if link < 0 and body in self.world.mesh_boxes:
            pos, orn = c.getBasePositionAndOrientation(body)
            dims = tuple(2.0 * h for h in self.world.mesh_boxes[body])
            placed.append((GEOM_BOX, dims, np.asarray(pos), np.asarray(c.getMatrixFromQuaternion(orn)).reshape(3, 3)))
        elif key in self._solids:
            frame = c.getBasePositionAndOrientation(body) if link < 0 else c.getLinkState(body, link)[:2]
            for geom, dims, local_pos, local_orn in self._solids[key]:
                pos, orn = c.multiplyTransforms(frame[0], frame[1], local_pos, local_orn)
                placed.append((geom, dims, np.asarray(pos), np.asarray(c.getMatrixFromQuaternion(orn)).reshape(3, 3)))
        frames[key] = placed
        return placed

    def _holds(self, body: int, link: int, point: np.ndarray, frames: dict[tuple[int, int], list[Any]]) -> bool:
        """True if ``point`` lies inside (by more than ``INSIDE``) one of the convex primitives of ``body``'s
        ``link``, or inside a mesh box."""
        for geom, dims, pos, rot in self._placed(body, link, frames):
            q = (point - pos) @ rot  # the point in the shape's frame
            if geom == GEOM_BOX:  # full edge lengths
                if (np.abs(q) < np.asarray(dims) / 2.0 - INSIDE).all():
                    return True
                continue
            if geom == GEOM_CYLINDER:  # (height, radius), along z
                if abs(q[2]) < dims[0] / 2.0 - INSIDE and q[0] ** 2 + q[1] ** 2 < (dims[1] - INSIDE) ** 2:
                    return True
                continue
            if geom == GEOM_SPHERE:
                radius = dims[0]
            else:  # a capsule along z: (length between the caps' centres, radius)
                radius = dims[1]
                q[2] -= min(max(q[2], -dims[0] / 2.0), dims[0] / 2.0)
            if float(q @ q) < (radius - INSIDE) ** 2:
                return True
        return False

    def _beyond_solid_starts(self, starts: np.ndarray, ends: np.ndarray, results: Any) -> Any:
        """``rayTestBatch``'s ``results`` for the segments ``starts[k] -> ends[k]`` ((n, 3)), each answer at
        fraction 0 on a convex primitive that holds the segment's start replaced by the nearest surface along the
        segment of a shape that does not hold it (see the module doc)."""
        solids = self._solids
        frames: dict[tuple[int, int], list[Any]] = {}
        redo = [k for k, r in enumerate(results)
                if r[2] < START_HIT and (r[0], r[1]) in solids and self._holds(r[0], r[1], starts[k], frames)]
        if not redo:
            return results
        out = list(results)
        best: dict[int, Any] = dict.fromkeys(redo, _NO_HIT)
        for number in range(MAX_HITS):
            hits = self.client.rayTestBatch(starts[redo], ends[redo], numThreads=1, collisionFilterMask=self.mask,
                                            reportHitNumber=number)
            left = []
            for k, hit in zip(redo, hits, strict=True):
                if hit[0] < 0:
                    continue
                left.append(k)
                if hit[2] < best[k][2] and not self._holds(hit[0], hit[1], starts[k], frames):
                    best[k] = hit
            if not left:
                break
            redo = left
        for k, hit in best.items():
            out[k] = hit
        return out

    def _intersect(self, d_t: np.ndarray, inv_len: np.ndarray, body: np.ndarray, frac: np.ndarray,
                   pos: np.ndarray | None, normal: np.ndarray | None) -> np.ndarray:
        """Fill in place the rays' nearest mesh-box hits that Bullet reports alike; return per ray whether
        PyBullet must cast it.

        ``d_t``: segment vectors, shape (3, N); the starts are in ``self._starts_h``; ``inv_len``: 1 / each
        segment's length (it scales the tolerances into fractions of the segment).

        Every box is first tested grown by its tolerance (Bullet's hits lie on the grown box: a triangle hit is
        accepted up to the tolerance outside the triangle); the nearest grown entry names the box, whose exact hit
        is then computed. The answer is PyBullet's unless another box's grown entry comes at or before it, or the
        hit itself is borderline (see below), or the segment up to the hit (or its end) crosses the bounding box
        of any other body (tested in the same pass, as rows after the boxes'): those rays are cast by PyBullet.
        A scan runs cold in the caches, where each numpy call costs several times its warm time: the steps below
        are merged into as few calls as give the same numbers.
        """
        n = d_t.shape[1]
        nb, rows = len(self._boxes), self._grown.shape[1]
        # starts and segments in each row's frame, (3, R, N): one small matrix product each
        if self._grown_full.shape != (3, rows, n):
            self._grown_full = np.repeat(self._grown[:, :, None], n, axis=2)
            self._work = np.empty((3, 3, rows, n))  # buffers reused between casts (less memory traffic)
            self._cols = np.arange(n)
            self._checks = np.empty((5, n), dtype=bool)
        elif rows > nb:  # (a product of whole arrays runs faster than a broadcast one)
            self._grown_full[:, nb:] = self._grown[:, nb:, None]
        noi, ninv, reach = self._work
        frame = self._frame.reshape(-1, 4)
        np.matmul(frame, self._starts_h, out=noi.reshape(-1, n))  # o, the starts in each row's frame
        np.matmul(frame[:, :3], d_t, out=ninv.reshape(-1, n))  # d, the segments
        # no division by zero: an axis the ray runs parallel to gets a tiny component (huge fractions, no overflow:
        # |1 / 1e-300| and metres times it stay finite); adding it leaves every other component as it is (it is far
        # below their last bit)
        ninv += _TINY
        np.divide(-1.0, ninv, out=ninv)  # -1 / d (negated: -o / d is then one product)
        np.multiply(noi, ninv, out=noi)  # -o / d
        np.abs(ninv, out=reach)
        reach *= self._grown_full  # h / |d|
        g_far = np.add(noi, reach).min(axis=0)
        g_all = np.subtract(noi, reach, out=reach).max(axis=0)  # slab entry per axis: (-h - o) / d for d > 0, ...
        # the grown entry per row and ray, (R, N): +inf where the segment's line misses the box or it lies behind
        # (entries before the start count as 0: the start lies in the grown box, a ray PyBullet casts either way;
        # fmax makes a NaN entry 0 too, and a NaN exit keeps the entry: both cast)
        np.fmax(g_all, 0.0, out=g_all)
        np.copyto(g_all, np.inf, where=g_all > g_far)
        g_hit = g_all[:nb]
        # the named box (the nearest grown entry, the first on ties) and the next box's grown entry
        first = g_hit.argmin(axis=0)
        flat = first * n
        flat += self._cols
        g_flat = g_hit.reshape(-1)
        g_first = g_flat.take(flat)
        g_flat[flat] = np.inf
        second = g_hit.min(axis=0)
        named = self._box_table.take(first, axis=1)  # the named box's tolerance, half extents (3) and id
        tolf = named[0]
        tf = tolf * inv_len
        # exact slabs of the named box, (3, N)
        nof, nidf = self._work[:2].reshape(2, 3, -1).take(flat, axis=2)  # noi and ninv at the named box
        aif = np.abs(nidf)
        h_ai = np.multiply(named[1:4], aif)
        lo = nof - h_ai
        t_near = lo.max(axis=0)
        t_far = np.add(nof, h_ai, out=nof).min(axis=0)
        entry = lo.argmax(axis=0)  # the entry face's axis
        at_entry = entry * n
        at_entry += self._cols
        lo_flat = lo.reshape(-1)
        tol_entry = tolf * aif.reshape(-1).take(at_entry)
        lo_flat[at_entry] = -np.inf
        # Clean if: the named box is hit (not behind the start); no other box's grown entry comes before the hit
        # plus the tolerance; the ray starts outside the grown box and ends well past the hit; and it crossed each
        # other front face's plane at least the tolerance outside that face (Bullet accepts a plane crossing up to
        # the tolerance outside its face and reports the first one). Between crossing face j's plane (lo_j) and the
        # entry face's (axis a, at t_near) the ray closes in on slab a by (t_near - lo_j) * |d_a|: at least that far
        # outside face j it crossed j's plane. (A clean ray is a candidate: its grown entry is within the segment.)
        checks = self._checks
        np.less_equal(np.maximum(t_near, 0.0), t_far, out=checks[0])
        np.greater(second, t_near + tf, out=checks[1])
        np.greater(g_first, 0.0, out=checks[2])
        np.less_equal(t_near, 1.0 - tf, out=checks[3])
        np.greater_equal(t_near - lo.max(axis=0), tol_entry, out=checks[4])
        clean = checks.all(axis=0)
        # not a candidate (no box's grown entry lies within the segment): no hit, and nothing to cast
        need = np.less_equal(g_first, 1.0 + tf)
        need ^= clean
        if rows > nb:  # another body's (padded) bounding box entered before the hit or the segment's end
            best = np.where(clean, t_near, 1.0)
            best += AABB_PAD * inv_len
            need |= g_all[nb:].min(axis=0) <= best
        np.copyto(frac, t_near, where=clean)
        np.copyto(body, named[4], where=clean, casting="unsafe")
        if pos is not None and normal is not None and clean.any():
            k = clean.nonzero()[0]
            pos[k] = (self._starts_h[:3, k] + d_t[:, k] * t_near[k]).T
            ek = entry[k]
            # outward normal of the entry face: box axis ek, against the ray's direction along it
            normal[k] = self._rot[first[k], :, ek] * np.sign(nidf.reshape(-1).take(ek * n + k))[:, None]
        return need
