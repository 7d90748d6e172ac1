"""RRT-Connect in a box of R^n, with path shortcutting: the sampling planner behind arm motion planning.

The space is a box ``lower <= q <= upper`` (an arm's joint limits, radians). A configuration is free when the
caller's ``free(q)`` says so; a straight segment is free when every point on it, at most ``resolution`` apart in
every coordinate, is free (:func:`segment_free`). Everything random draws from the ``numpy.random.Generator`` the
caller hands in: the same generator state gives the same path.

RRT-Connect (Kuffner and LaValle, 2000) grows one tree from the start and one from the goal. Each round one tree
takes one step of at most ``step`` towards a random sample; the other tree then steps greedily towards that new node
until it reaches it (the trees meet: a path) or is blocked. The trees swap roles every round. The path is then
shortened: random pairs of its points joined by a free straight segment cut out what lay between them
(:func:`shortcut`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

Vector = Sequence[float] | np.ndarray
"""A configuration: one value per coordinate (an arm's joints, radians)."""
Free = Callable[[np.ndarray], bool]
"""Is a configuration free (no collision)? Called with one configuration, shape ``(n,)``."""


@dataclass
class Search:
    """What a :func:`rrt_connect` call found and what it cost.

    Attributes:
        path: Configurations from start to goal (each a free straight segment from the last), or None.
        samples: Random samples drawn.
        nodes: Nodes in both trees at the end.
        checks: Configurations given to ``free``.
    """

    path: list[np.ndarray] | None
    samples: int = 0
    nodes: int = 0
    checks: int = 0


@dataclass
class _Tree:
    """Nodes (rows of a growing array) and each one's parent index (-1 for the root)."""

    points: np.ndarray
    parents: list[int] = field(default_factory=lambda: [-1])
    size: int = 1

    def nearest(self, q: np.ndarray) -> int:
        d = self.points[:self.size] - q
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def add(self, q: np.ndarray, parent: int) -> int:
        if self.size == len(self.points):
            self.points = np.concatenate([self.points, np.empty_like(self.points)])
        self.points[self.size] = q
        self.parents.append(parent)
        self.size += 1
        return self.size - 1

    def branch(self, node: int) -> list[np.ndarray]:
        """The configurations from ``node`` back to the root."""
        out = []
        while node != -1:
            out.append(self.points[node].copy())
            node = self.parents[node]
        return out


class _Counter:
    """Counts calls of ``free``."""

    def __init__(self, free: Free) -> None:
        self.free, self.calls = free, 0

    def __call__(self, q: np.ndarray) -> bool:
        self.calls += 1
        return self.free(q)


def segment_free(a: np.ndarray, b: np.ndarray, free: Free, resolution: float) -> bool:
    """Is the straight segment from ``a`` to ``b`` free? Points at most ``resolution`` apart in every coordinate,
    ``b`` included, ``a`` not (it is known to be free)."""
    steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / resolution))
    return all(free(a + (k / steps) * (b - a)) for k in range(1, steps + 1))


def rrt_connect(start: Vector, goal: Vector, *, lower: Vector, upper: Vector,
                free: Free, rng: np.random.Generator, step: float = 0.4, resolution: float = 0.02,
                max_samples: int = 4000) -> Search:
    """A free path from ``start`` to ``goal`` (both free, inside the box), or ``Search(path=None)`` after
    ``max_samples`` samples.

    Args:
        start, goal: Configurations, shape ``(n,)``.
        lower, upper: The box, shape ``(n,)``.
        free: Is a configuration free?
        rng: The only source of randomness.
        step: Longest step a tree takes towards a sample (Euclidean, in the space's units).
        resolution: Spacing of the checks along a segment, per coordinate.
        max_samples: Samples before giving up.
    """
    free_n = _Counter(free)
    q0, q1 = np.asarray(start, float), np.asarray(goal, float)
    lo, hi = np.asarray(lower, float), np.asarray(upper, float)
    search = Search(None)
    if segment_free(q0, q1, free_n, resolution):
        search.path, search.checks, search.nodes = [q0, q1], free_n.calls, 2
        return search
    trees = [_Tree(np.tile(q0, (64, 1))), _Tree(np.tile(q1, (64, 1)))]
    for sample in range(1, max_samples + 1):
        a, b = trees[(sample - 1) % 2], trees[sample % 2]
        q_new = _extend(a, rng.uniform(lo, hi), free_n, step, resolution)
        if q_new is not None and _connect(b, a.points[q_new], free_n, step, resolution):
            branch_a, branch_b = a.branch(q_new), b.branch(b.size - 1)[1:]
            path = branch_a[::-1] + branch_b
            search.path = path if a is trees[0] else path[::-1]
            search.samples = sample
            break
        search.samples = sample
    search.nodes, search.checks = trees[0].size + trees[1].size, free_n.calls
    return search


def _extend(tree: _Tree, target: np.ndarray, free: Free, step: float, resolution: float) -> int | None:
    """One step of ``tree`` towards ``target``: the new node's index, or None if the step is blocked."""
    near = tree.nearest(target)
    q_near = tree.points[near]
    d = target - q_near
    dist = float(np.linalg.norm(d))
    if dist < 1e-12:
        return None
    q = target.copy() if dist <= step else q_near + d * (step / dist)
    if not segment_free(q_near, q, free, resolution):
        return None
    return tree.add(q, near)


def _connect(tree: _Tree, target: np.ndarray, free: Free, step: float, resolution: float) -> bool:
    """Step ``tree`` towards ``target`` until it gets there (True; its last node is ``target``) or is blocked."""
    while True:
        node = _extend(tree, target, free, step, resolution)
        if node is None:
            return False
        if np.array_equal(tree.points[node], target):
            return True


def shortcut(path: Sequence[Vector], free: Free, rng: np.random.Generator, *, resolution: float = 0.02,
             rounds: int = 60) -> list[np.ndarray]:
    """A shorter free path with the same ends: ``rounds`` random pairs of points on the path (anywhere along its
    segments) joined straight when that segment is free; then every waypoint that its neighbours can skip is
    dropped."""
    pts = [np.asarray(p, float) for p in path]
    for _ in range(rounds):
        if len(pts) < 3:
            break
        lengths = np.linalg.norm(np.diff(np.array(pts), axis=0), axis=1)
        total = float(lengths.sum())
        if total <= 0:
            break
        s, t = np.sort(rng.uniform(0.0, total, 2))
        i, a = _point_at(pts, lengths, float(s))
        j, b = _point_at(pts, lengths, float(t))
        if j <= i or not segment_free(a, b, free, resolution):
            continue
        pts = pts[:i + 1] + [a, b] + pts[j + 1:]
        pts = [p for k, p in enumerate(pts) if k == 0 or not np.allclose(p, pts[k - 1], atol=1e-9)]
    k = 1
    while k < len(pts) - 1:
        if segment_free(pts[k - 1], pts[k + 1], free, resolution):
            del pts[k]
        else:
            k += 1
    return pts


def _point_at(pts: list[np.ndarray], lengths: np.ndarray, s: float) -> tuple[int, np.ndarray]:
    """The segment index ``i`` and the point ``s`` along the path (it lies between ``pts[i]`` and ``pts[i+1]``)."""
    ends = np.cumsum(lengths)
    i = min(int(np.searchsorted(ends, s)), len(lengths) - 1)
    before = float(ends[i] - lengths[i])
    f = 0.0 if lengths[i] <= 0 else (s - before) / float(lengths[i])
    return i, pts[i] + min(max(f, 0.0), 1.0) * (pts[i + 1] - pts[i])


def path_length(path: Sequence[Vector]) -> float:
    """Sum of the Euclidean lengths of a path's segments."""
    return float(sum(np.linalg.norm(np.asarray(b) - np.asarray(a)) for a, b in zip(path, path[1:], strict=False)))


def densify(path: Sequence[Vector], resolution: float) -> np.ndarray:
    """The path's points at most ``resolution`` apart in every coordinate, its waypoints included (rows)."""
    out = [np.asarray(path[0], float)]
    for a, b in zip(path, path[1:], strict=False):
        a, b = np.asarray(a, float), np.asarray(b, float)
        steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / resolution))
        out.extend(a + (k / steps) * (b - a) for k in range(1, steps + 1))
    return np.array(out)


def resample(path: Sequence[Vector], spacing: float) -> np.ndarray:
    """Points along the path at equal Euclidean spacing (at most ``spacing``), both ends included (rows): a path
    whose segments all take the same time when followed point by point. Corners are kept."""
    out = [np.asarray(path[0], float)]
    for a, b in zip(path, path[1:], strict=False):
        a, b = np.asarray(a, float), np.asarray(b, float)
        steps = max(1, math.ceil(float(np.linalg.norm(b - a)) / spacing))
        out.extend(a + (k / steps) * (b - a) for k in range(1, steps + 1))
    return np.array(out)
