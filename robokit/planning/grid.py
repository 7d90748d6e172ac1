"""A 2-D occupancy grid in log-odds, updated from laser scans by ray tracing, with a clearance field.

Cell ``(i, j)`` covers ``x in [x0 + i*res, x0 + (i+1)*res)`` and ``y in [y0 + j*res, y0 + (j+1)*res)`` (m, world
frame); arrays are indexed ``[i, j]`` (x first). Each scan lowers the log-odds of the cells its rays cross
(``free``) and raises the log-odds of the cell each return lands in (``hit``); values are clamped so a moved
obstacle is forgotten after a few scans. A cell is *occupied* above ``occupied_above``; cells never seen stay at
0 (unknown) and count as free for planning (an optimistic planner that replans when it learns otherwise).

:meth:`OccupancyGrid.clearance` is the distance from each cell centre to the nearest occupied cell centre, capped
at ``clearance_cap``: the planner forbids cells closer than the robot's radius and prefers cells further away.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.msgs.mobile import LaserScan


class GridConfig(Schema):
    """Occupancy grid parameters.

    Attributes:
        resolution: Cell size, m.
        margin: The grid spans the start, the goals and the static bodies plus this much on every side, m.
        extent: Explicit area ``(xmin, ymin, xmax, ymax)``, m, world frame (empty: computed as above).
        hit: Log-odds added to the cell a return lands in.
        free: Log-odds added to each cell a ray crosses (negative).
        clamp: Log-odds are kept within ``[-clamp, clamp]``.
        occupied_above: A cell is occupied when its log-odds exceed this.
        ground_height: Returns lower than this (m, world z) are the floor: their ray is free, the end no obstacle.
    """

    resolution: float = Field(0.05, gt=0.005, le=1.0)
    margin: float = Field(2.0, ge=0)
    extent: tuple[float, ...] = ()
    hit: float = Field(0.9, gt=0)
    free: float = Field(-0.4, lt=0)
    clamp: float = Field(3.5, gt=0)
    occupied_above: float = Field(0.6, ge=0)
    ground_height: float = Field(0.03, ge=0)


class OccupancyGrid:
    """Log-odds occupancy grid over a rectangle of the floor (see the module docstring).

    Args:
        lo: Lower corner ``(xmin, ymin)``, m, world frame.
        hi: Upper corner ``(xmax, ymax)``, m.
        cfg: Grid parameters.
        clearance_cap: Clearances are computed up to this distance, m (further is reported as the cap).
    """

    def __init__(self, lo: Sequence[float], hi: Sequence[float], cfg: GridConfig, clearance_cap: float) -> None:
        self.cfg = cfg
        self.res = cfg.resolution
        self.origin = (float(lo[0]), float(lo[1]))
        self.shape = (max(1, math.ceil((hi[0] - lo[0]) / self.res)), max(1, math.ceil((hi[1] - lo[1]) / self.res)))
        self.logodds = np.zeros(self.shape, dtype=np.float32)
        self.cap = clearance_cap
        self._reach = math.ceil(clearance_cap / self.res)
        self._occupied = np.zeros(self.shape, dtype=bool)
        self._clearance = np.full(self.shape, clearance_cap, dtype=np.float32)
        self.version = 0
        """Counts changes of the occupied set (a planner replans when it moves)."""

    # ------------------------------------------------------------------ geometry
    def cell(self, x: float, y: float) -> tuple[int, int]:
        """The cell holding world point (x, y), clipped to the grid."""
        i = int(math.floor((x - self.origin[0]) / self.res))
        j = int(math.floor((y - self.origin[1]) / self.res))
        return min(max(i, 0), self.shape[0] - 1), min(max(j, 0), self.shape[1] - 1)

    def inside(self, x: float, y: float) -> bool:
        """True if (x, y) lies on the grid."""
        i = (x - self.origin[0]) / self.res
        j = (y - self.origin[1]) / self.res
        return 0 <= i < self.shape[0] and 0 <= j < self.shape[1]

    def centre(self, i: int, j: int) -> tuple[float, float]:
        """World (x, y) of a cell's centre, m."""
        return self.origin[0] + (i + 0.5) * self.res, self.origin[1] + (j + 0.5) * self.res

    def cells_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell indices ``(i, j)`` of world points ``(n, 2)`` and a mask of those on the grid."""
        ij = np.floor((xy - np.asarray(self.origin)) / self.res).astype(np.int64)
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < self.shape[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < self.shape[1])
        return ij[:, 0], ij[:, 1], ok

    # ------------------------------------------------------------------ updates
    def mark_boxes(self, boxes: Iterable[tuple[float, float, float, float]]) -> None:
        """Seed a known map: cells whose centres lie in the boxes ``(xmin, ymin, xmax, ymax)`` (m) become certainly
        occupied (until scans see through them)."""
        xs = self.origin[0] + (np.arange(self.shape[0]) + 0.5) * self.res
        ys = self.origin[1] + (np.arange(self.shape[1]) + 0.5) * self.res
        for x0, y0, x1, y1 in boxes:
            ii = (xs >= x0 - self.res / 2) & (xs <= x1 + self.res / 2)
            jj = (ys >= y0 - self.res / 2) & (ys <= y1 + self.res / 2)
            self.logodds[np.ix_(ii, jj)] = self.cfg.clamp
        self._refresh()

    def update(self, scan: LaserScan, ignore: tuple[float, float, float] | None = None) -> bool:
        """Fold one scan in; returns True if the occupied set changed.

        Args:
            scan: A laser scan (world-frame points, origin, ranges).
            ignore: ``(x, y, radius)``: returns inside this circle are not obstacles (an object being collected).
        """
        ranges = np.asarray(scan.ranges, dtype=float)
        hit = np.isfinite(ranges)
        pts = np.asarray(scan.points, dtype=float)
        ends = pts[:, :2].copy()
        floor = hit & (pts[:, 2] <= self.cfg.ground_height)
        solid = hit & ~floor
        if ignore is not None:
            solid &= np.hypot(ends[:, 0] - ignore[0], ends[:, 1] - ignore[1]) > ignore[2]
        origin = np.asarray(scan.origin[:2], dtype=float)
        length = np.hypot(ends[:, 0] - origin[0], ends[:, 1] - origin[1])
        step = self.res
        ts = np.arange(step, float(length.max(initial=0.0)) + step, step)
        free = np.zeros(self.logodds.size, dtype=bool)
        if len(ts):
            reach = np.where(solid, length - self.res * 0.75, length)[:, None]
            along = ts[None, :] <= reach
            frac = ts[None, :] / np.maximum(length, 1e-9)[:, None]
            xs = origin[0] + (ends[:, 0:1] - origin[0]) * frac
            ys = origin[1] + (ends[:, 1:2] - origin[1]) * frac
            fi, fj, ok = self.cells_of(np.stack([xs[along], ys[along]], 1))
            free[fi[ok] * self.shape[1] + fj[ok]] = True
        hi, hj, ok = self.cells_of(ends[solid])
        occ = np.zeros(self.logodds.size, dtype=bool)
        occ[hi[ok] * self.shape[1] + hj[ok]] = True
        free &= ~occ
        flat = self.logodds.reshape(-1)
        flat[free] = np.maximum(flat[free] + self.cfg.free, -self.cfg.clamp)
        flat[occ] = np.minimum(flat[occ] + self.cfg.hit, self.cfg.clamp)
        return self._refresh()

    def _refresh(self) -> bool:
        occupied = self.logodds > self.cfg.occupied_above
        if np.array_equal(occupied, self._occupied):
            return False
        self._occupied = occupied
        self._clearance = self._distance(occupied)
        self.version += 1
        return True

    def _distance(self, occupied: np.ndarray) -> np.ndarray:
        """Distance from each cell centre to the nearest occupied cell centre, m, capped: exact within the cap,
        computed in two passes (nearest occupied cell along each column, then the best column nearby)."""
        r = self._reach
        n, m = self.shape
        rows = np.pad(occupied, ((r, r), (0, 0)))
        col = np.full((n, m + 2 * r), np.inf, dtype=np.float32)  # squared cells to the nearest in the column
        inner = col[:, r:r + m]
        for d in range(r, -1, -1):  # nearer offsets overwrite further ones
            inner[rows[r + d:r + d + n] | rows[r - d:r - d + n]] = d * d
        best = np.full(self.shape, np.inf, dtype=np.float32)
        tmp = np.empty(self.shape, dtype=np.float32)
        for d in range(-r, r + 1):
            np.add(col[:, r + d:r + d + m], d * d, out=tmp)
            np.minimum(best, tmp, out=best)
        return np.minimum(np.sqrt(best) * self.res, self.cap).astype(np.float32)

    # ------------------------------------------------------------------ queries
    @property
    def occupied(self) -> np.ndarray:
        """Boolean ``shape`` array: cells believed occupied."""
        return self._occupied

    @property
    def known(self) -> np.ndarray:
        """Boolean ``shape`` array: cells seen at least once (or seeded)."""
        return self.logodds != 0

    @property
    def clearance(self) -> np.ndarray:
        """Distance to the nearest occupied cell, m, per cell (capped)."""
        return self._clearance

    def clearance_at(self, xy: np.ndarray) -> np.ndarray:
        """Clearance (m) at world points ``(..., 2)``; points off the grid get 0 (the grid's edge is a wall)."""
        flat = xy.reshape(-1, 2)
        i, j, ok = self.cells_of(flat)
        out = np.zeros(len(flat), dtype=np.float32)
        out[ok] = self._clearance[i[ok], j[ok]]
        return out.reshape(xy.shape[:-1])

    # ------------------------------------------------------------------ export
    def to_pgm(self) -> bytes:
        """The grid as a binary PGM in ROS ``map_server``'s convention: occupied 0 (black), free 254, unknown 205;
        the image's top row is the grid's largest y."""
        img = np.full(self.shape, 205, dtype=np.uint8)
        img[self.logodds < 0] = 254
        img[self._occupied] = 0
        rows = np.ascontiguousarray(img.T[::-1])
        return f"P5\n{self.shape[0]} {self.shape[1]}\n255\n".encode() + rows.tobytes()

    def map_yaml(self, image: str) -> str:
        """ROS ``map_server`` metadata for :meth:`to_pgm` saved as ``image``."""
        return (f"image: {image}\nresolution: {self.res}\norigin: [{self.origin[0]:.4f}, {self.origin[1]:.4f}, 0.0]\n"
                "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")

