"""RRT-Connect and shortcutting in a 2-D toy space: paths judged by plain segment-against-box geometry (not by the
planner's own sampled checks), the same seed giving the same path, no path when the goal is walled in."""

from __future__ import annotations

import numpy as np
import pytest

from robokit.planning.rrt import path_length, resample, rrt_connect, shortcut

LOWER, UPPER = np.zeros(2), np.ones(2)
WALLS = [((0.45, 0.0), (0.55, 0.8)), ((0.2, 0.9), (0.8, 0.95))]
"""Boxes ``(low corner, high corner)``: a wall up from the floor and a bar above its top (a narrow way over)."""


MARGIN = 0.01
"""The planner keeps this clearance (checks at points 0.005 apart could cut a bare corner between two of them)."""


def free(q: np.ndarray) -> bool:
    """The planner's check: outside every wall grown by the margin."""
    return not any(lo[0] - MARGIN < q[0] < hi[0] + MARGIN and lo[1] - MARGIN < q[1] < hi[1] + MARGIN
                   for lo, hi in WALLS)


def segment_hits_box(a: np.ndarray, b: np.ndarray, lo: tuple[float, float], hi: tuple[float, float]) -> bool:
    """Does the segment a-b enter the open box (the bare wall, no margin)? Slab clipping (Liang-Barsky)."""
    t0, t1 = 0.0, 1.0
    for k in range(2):
        d = b[k] - a[k]
        if abs(d) < 1e-15:
            if not lo[k] < a[k] < hi[k]:
                return False
            continue
        s0, s1 = sorted(((lo[k] - a[k]) / d, (hi[k] - a[k]) / d))
        t0, t1 = max(t0, s0), min(t1, s1)
    return t1 - t0 > 1e-9


def collision_free(path: list[np.ndarray]) -> bool:
    return not any(segment_hits_box(a, b, lo, hi) for a, b in zip(path, path[1:], strict=False) for lo, hi in WALLS)


def test_a_path_around_the_wall_is_free_by_geometry_and_the_same_for_a_seed() -> None:
    start, goal = np.array([0.1, 0.1]), np.array([0.9, 0.1])
    runs = [rrt_connect(start, goal, lower=LOWER, upper=UPPER, free=free, rng=np.random.default_rng(4), step=0.15,
                        resolution=0.005) for _ in range(2)]
    path = runs[0].path
    assert path is not None and runs[0].samples > 0
    assert np.array_equal(path[0], start) and np.array_equal(path[-1], goal)
    assert collision_free(path)
    assert all(np.array_equal(a, b) for a, b in zip(path, runs[1].path or [], strict=True))
    # the way round goes between the wall's top (0.8) and the bar (0.9)
    assert max(q[1] for q in path) > 0.8 and path_length(path) > 1.6 - 1e-9  # 2 x hypot(0.35, 0.7) + 0.1 - a bit


@pytest.mark.parametrize("seed", range(5))
def test_shortcutting_keeps_the_ends_and_freedom_and_never_lengthens(seed: int) -> None:
    start, goal = np.array([0.1, 0.1]), np.array([0.9, 0.1])
    found = rrt_connect(start, goal, lower=LOWER, upper=UPPER, free=free, rng=np.random.default_rng(seed), step=0.1,
                        resolution=0.005)
    assert found.path is not None and collision_free(found.path)
    short = shortcut(found.path, free, np.random.default_rng(seed), resolution=0.005, rounds=80)
    assert np.array_equal(short[0], start) and np.array_equal(short[-1], goal)
    assert collision_free(short)
    assert path_length(short) <= path_length(found.path) + 1e-12
    shortest = 2 * np.hypot(0.35, 0.7) + 0.1  # over the bare wall's top corners (0.45, 0.8) and (0.55, 0.8)
    assert shortest - 1e-9 <= path_length(short) < 1.3 * shortest


def test_a_clear_straight_way_is_taken_without_sampling() -> None:
    found = rrt_connect([0.1, 0.85], [0.9, 0.85], lower=LOWER, upper=UPPER, free=free, rng=np.random.default_rng(0))
    assert found.samples == 0 and found.path is not None and len(found.path) == 2


def test_a_walled_in_goal_gives_no_path_after_the_sample_budget() -> None:
    def boxed(q: np.ndarray) -> bool:
        inside = 0.6 < q[0] < 0.9 and 0.6 < q[1] < 0.9
        ring = 0.55 < q[0] < 0.95 and 0.55 < q[1] < 0.95
        return inside or not ring

    found = rrt_connect([0.1, 0.1], [0.75, 0.75], lower=LOWER, upper=UPPER, free=boxed,
                        rng=np.random.default_rng(0), max_samples=150)
    assert found.path is None and found.samples == 150


def test_resampled_points_are_evenly_spaced_and_keep_the_corners() -> None:
    corners = [np.array([0.0, 0.0]), np.array([0.3, 0.0]), np.array([0.3, 0.4])]
    points = resample(corners, 0.07)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert steps.max() <= 0.07 + 1e-12
    assert any(np.allclose(p, corners[1]) for p in points)
    assert np.allclose(points[0], corners[0]) and np.allclose(points[-1], corners[-1])
    assert abs(steps.sum() - 0.7) < 1e-12
