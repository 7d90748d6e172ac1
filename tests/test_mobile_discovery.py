"""discovery.fit_circle: the centre of a can of known radius from the lidar points on its near side."""

from __future__ import annotations

import numpy as np
from robokit_behaviours.discovery import fit_circle


def _arc(centre: np.ndarray, radius: float, origin: np.ndarray, n: int, noise: float,
         rng: np.random.Generator) -> np.ndarray:
    facing = np.arctan2(*(origin - centre)[::-1])
    angles = facing + np.linspace(-0.9, 0.9, n)
    points = centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return points + rng.normal(0.0, noise, points.shape)


def _gauss_newton_lstsq(points: np.ndarray, start: np.ndarray, radius: float, iterations: int = 30) -> np.ndarray:
    """Reference: the same least-squares problem solved with numpy's SVD solver."""
    centre = start.copy()
    for _ in range(iterations):
        d = points - centre
        dist = np.hypot(d[:, 0], d[:, 1])
        step, *_ = np.linalg.lstsq(-d / dist[:, None], -(dist - radius), rcond=None)
        centre = centre + step
    return centre


def test_exact_points_give_the_centre() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        centre, origin = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        if np.linalg.norm(origin - centre) < 0.3:
            continue
        found = fit_circle(_arc(centre, 0.033, origin, int(rng.integers(3, 12)), 0.0, rng), origin, 0.033)
        assert np.linalg.norm(found - centre) < 1e-9


def test_noisy_points_give_the_least_squares_centre() -> None:
    rng = np.random.default_rng(1)
    for _ in range(100):
        centre, origin = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        if np.linalg.norm(origin - centre) < 0.3:
            continue
        points = _arc(centre, 0.033, origin, 8, 0.003, rng)
        found = fit_circle(points, origin, 0.033)
        reference = _gauss_newton_lstsq(points, found, 0.033)
        assert np.linalg.norm(found - reference) < 1e-7  # the same minimum as numpy's solver
        assert np.linalg.norm(found - centre) < 0.01


def test_too_few_points_keep_the_geometric_guess() -> None:
    origin = np.array([0.0, 0.0])
    single = np.array([[1.0, 0.0], [1.0, 0.0]])  # one point twice: no curvature to fit
    found = fit_circle(single, origin, 0.05)
    assert np.allclose(found, [1.05, 0.0])
