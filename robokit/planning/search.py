"""A* on a clearance field: 8-connected, cells closer than the robot's radius to an obstacle forbidden, cells
within a soft margin beyond it dearer (the path keeps off walls where there is room), then shortened by line of
sight.

Plain Python with :mod:`heapq`: grids of a room (tens of thousands of cells) plan in milliseconds to tens of
milliseconds.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence

import numpy as np

Cell = tuple[int, int]

_STEPS = [(1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
          (1, 1, math.sqrt(2)), (1, -1, math.sqrt(2)), (-1, 1, math.sqrt(2)), (-1, -1, math.sqrt(2))]


def astar(clearance: np.ndarray, start: Cell, goal: Cell, radius: float, res: float, margin: float = 0.0,
          penalty: float = 0.0) -> list[Cell] | None:
    """Cheapest 8-connected cell path from ``start`` to ``goal``, or None if there is none.

    Args:
        clearance: Distance to the nearest obstacle per cell, m (``[i, j]``).
        start: Start cell. If it is closer than ``radius`` to an obstacle, the search may leave it through cells
            whose clearance does not fall (the robot backs out of a tight spot).
        goal: Goal cell (must have clearance >= ``radius``, else no path).
        radius: Cells with less clearance are forbidden, m.
        res: Cell size, m (costs and the heuristic are in metres).
        margin: Cells with clearance below ``radius + margin`` cost more ...
        penalty: ... up to ``1 + penalty`` times a step's length at clearance ``radius``.
    """
    n, m = clearance.shape
    clear = clearance.ravel().tolist()
    gi, gj = goal
    if clear[gi * m + gj] < radius:
        return None
    soft = radius + margin

    def weight(c: float) -> float:
        return 1.0 + (penalty * (soft - c) / margin if margin > 0 and c < soft else 0.0)

    s = start[0] * m + start[1]
    g = gi * m + gj
    best = {s: 0.0}
    parent: dict[int, int] = {s: -1}
    heap = [(0.0, 0.0, s)]
    closed = set()
    while heap:
        _, cost, cur = heapq.heappop(heap)
        if cur == g:
            return _unwind(parent, g, m)
        if cur in closed:
            continue
        closed.add(cur)
        ci, cj = divmod(cur, m)
        c_here = clear[cur]
        for di, dj, length in _STEPS:
            ni, nj = ci + di, cj + dj
            if not (0 <= ni < n and 0 <= nj < m):
                continue
            nxt = ni * m + nj
            c = clear[nxt]
            if c < radius and not (c_here < radius and c >= c_here):  # forbidden, unless backing out
                continue
            new = cost + length * res * weight(c)
            if new < best.get(nxt, math.inf):
                best[nxt] = new
                parent[nxt] = cur
                h = res * (max(abs(gi - ni), abs(gj - nj)) + (math.sqrt(2) - 1) * min(abs(gi - ni), abs(gj - nj)))
                heapq.heappush(heap, (new + h, new, nxt))
    return None


def _unwind(parent: dict[int, int], goal: int, m: int) -> list[Cell]:
    path = []
    cur = goal
    while cur != -1:
        path.append(divmod(cur, m))
        cur = parent[cur]
    return path[::-1]


def line_clear(clearance: np.ndarray, a: Cell, b: Cell, radius: float) -> bool:
    """True if every cell on the segment between cell centres ``a`` and ``b`` has clearance >= ``radius``."""
    steps = max(abs(b[0] - a[0]), abs(b[1] - a[1])) * 2 + 1
    ii = np.rint(np.linspace(a[0], b[0], steps)).astype(int)
    jj = np.rint(np.linspace(a[1], b[1], steps)).astype(int)
    return bool((clearance[ii, jj] >= radius).all())


def shorten(clearance: np.ndarray, path: Sequence[Cell], radius: float) -> list[Cell]:
    """Drop cells of ``path`` while the straight segment from the last kept cell stays clear (string pulling,
    forward: each kept cell is joined to the furthest of the following cells it sees without a gap)."""
    if len(path) <= 2:
        return list(path)
    out = [path[0]]
    i = 0
    while i < len(path) - 1:
        j = i + 1
        while j + 1 < len(path) and line_clear(clearance, path[i], path[j + 1], radius):
            j += 1
        out.append(path[j])
        i = j
    return out


def path_length(points: Sequence[Sequence[float]]) -> float:
    """Length of a polyline of (x, y) points, m."""
    return float(sum(math.dist(a[:2], b[:2]) for a, b in zip(points, points[1:], strict=False)))
