"""robokit.planning's parts, each against an independent computation: the grid against scan geometry, the
clearance field against brute force, A* against a plain Dijkstra, replanning when a wall appears on the path, the
dynamic window against the acceleration limits and a fine-step integration of the chosen arc."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest

from robokit.msgs.mobile import LaserScan
from robokit.planning import DwaConfig, DynamicWindow, GridConfig, OccupancyGrid, PlanningConfig, PlanningNavigator
from robokit.planning.search import astar


def wall_scan(origin: tuple[float, float], wall_x: float, rays: int = 180) -> LaserScan:
    """A scan from ``origin`` (z 0.2 m) of an infinite wall at x = ``wall_x``: rays towards it hit, others reach
    range_max (5 m) with no return."""
    ang = -math.pi + 2 * math.pi * np.arange(rays) / rays
    dx, dy = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore"):
        r = np.where(dx > 1e-9, (wall_x - origin[0]) / np.where(dx > 1e-9, dx, 1.0), np.inf)
    ranges = np.where(r <= 5.0, r, np.inf)
    length = np.where(np.isfinite(ranges), ranges, 5.0)
    pts = np.stack([origin[0] + dx * length, origin[1] + dy * length, np.full(rays, 0.2)], 1)
    return LaserScan(float(ang[0]), float(ang[-1]), 2 * math.pi / rays, 0.05, 5.0, ranges, pts,
                     (origin[0], origin[1], 0.2), 0.0, 0.0)


def test_one_scan_marks_the_wall_occupied_and_the_space_before_it_free() -> None:
    grid = OccupancyGrid((-3, -3), (3, 3), GridConfig(resolution=0.1), clearance_cap=0.5)
    grid.update(wall_scan((0.0, 0.0), 1.0))
    xs = grid.origin[0] + (np.arange(grid.shape[0]) + 0.5) * grid.res
    ys = grid.origin[1] + (np.arange(grid.shape[1]) + 0.5) * grid.res
    occupied_x = xs[np.nonzero(grid.occupied)[0]]
    assert len(occupied_x) > 10 and np.all(np.abs(occupied_x - 1.0) <= grid.res)  # only the wall's column
    free = grid.logodds < 0
    x, y = np.meshgrid(xs, ys, indexing="ij")
    assert free[(np.hypot(x, y) < 0.9) & (x < 0.85)].all()  # every cell well before the wall was crossed
    assert not free[x > 1.2].any() and not grid.known[x > 1.2].any()  # nothing seen behind the wall
    left = grid.clearance[grid.cell(0.0, 0.0)]
    assert left == pytest.approx(1.0, abs=grid.res) or left == pytest.approx(0.5)  # 1 m to the wall, capped at 0.5


@pytest.mark.parametrize("seed", range(6))
def test_clearance_equals_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = OccupancyGrid((0, 0), (2.0, 1.5), GridConfig(resolution=0.05), clearance_cap=0.4)
    grid.logodds[rng.random(grid.shape) < 0.01] = 3.0
    grid.mark_boxes([])  # refresh from the log-odds
    oi, oj = np.nonzero(grid.occupied)
    ii, jj = np.indices(grid.shape)
    brute = np.hypot(ii[..., None] - oi, jj[..., None] - oj).min(axis=-1) * grid.res
    assert np.allclose(grid.clearance, np.minimum(brute, 0.4), atol=1e-5)


def dijkstra(allowed: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """Shortest 8-connected path length (in cells) through allowed cells, or inf."""
    dist = {start: 0.0}
    heap = [(0.0, start)]
    while heap:
        d, (i, j) = heapq.heappop(heap)
        if (i, j) == goal:
            return d
        if d > dist[(i, j)]:
            continue
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                n = (i + di, j + dj)
                if (di or dj) and 0 <= n[0] < allowed.shape[0] and 0 <= n[1] < allowed.shape[1] and allowed[n]:
                    nd = d + math.hypot(di, dj)
                    if nd < dist.get(n, math.inf):
                        dist[n] = nd
                        heapq.heappush(heap, (nd, n))
    return math.inf


@pytest.mark.parametrize("seed", range(12))
def test_astar_is_optimal_and_keeps_its_radius(seed: int) -> None:
    rng = np.random.default_rng(seed)
    clearance = np.where(rng.random((30, 24)) < 0.3, 0.0, 1.0)
    free = np.argwhere(clearance >= 0.5)
    start, goal = (tuple(int(v) for v in free[k]) for k in rng.choice(len(free), 2, replace=False))
    path = astar(clearance, start, goal, radius=0.5, res=1.0)
    best = dijkstra(clearance >= 0.5, start, goal)
    if path is None:
        assert best == math.inf
        return
    assert path[0] == start and path[-1] == goal
    steps = [(b[0] - a[0], b[1] - a[1]) for a, b in zip(path, path[1:], strict=False)]
    assert all(max(abs(di), abs(dj)) == 1 for di, dj in steps)
    assert all(clearance[c] >= 0.5 for c in path)
    assert sum(math.hypot(*s) for s in steps) == pytest.approx(best)


def test_a_wall_across_the_path_makes_it_replan_around() -> None:
    nav = PlanningNavigator(PlanningConfig(), (-1, -3), (5, 3))
    pose, goal = (0.0, 0.0, 0.0), (4.0, 0.0)
    nav.step(pose, (0.0, 0.0), None, goal, 0.0, 0.2)
    assert nav.path and max(abs(p[1]) for p in nav.path) < 0.05  # nothing known: straight on
    wall = np.array([[2.0, y] for y in np.arange(-1.0, 1.0, 0.02)])  # a wall from y = -1 to 1 at x = 2
    ang = np.arctan2(wall[:, 1], wall[:, 0])
    scan = LaserScan(float(ang[0]), float(ang[-1]), 0.01, 0.05, 5.0, np.hypot(wall[:, 0], wall[:, 1]),
                     np.column_stack([wall, np.full(len(wall), 0.2)]), (0.0, 0.0, 0.2), 0.0, 0.1)
    nav.step(pose, (0.0, 0.0), scan, goal, 0.1, 0.2)
    assert nav.stats.reasons.get("blocked") == 1
    assert max(abs(p[1]) for p in nav.path) > 1.0 + nav.cfg.robot_radius  # round an end of the wall
    for a, b in zip(nav.path, nav.path[1:], strict=False):  # no segment passes within the radius of the wall
        s = np.linspace(0, 1, 50)[:, None]
        seg = np.array(a) + s * (np.array(b) - np.array(a))
        assert np.hypot(seg[:, None, 0] - wall[:, 0], seg[:, None, 1] - wall[:, 1]).min() >= nav.cfg.robot_radius


@pytest.mark.parametrize("seed", range(20))
def test_dwa_keeps_to_the_window_and_off_an_obstacle(seed: int) -> None:
    rng = np.random.default_rng(seed)
    cfg = DwaConfig()
    dwa = DynamicWindow(cfg, radius=0.2, period=0.05)
    obstacle = rng.uniform(-1.0, 1.0, 2)
    pose = (0.0, 0.0, float(rng.uniform(-math.pi, math.pi)))
    if math.hypot(*obstacle) < 0.3:
        obstacle = obstacle / math.hypot(*obstacle) * 0.3
    v0, w0 = float(rng.uniform(0, cfg.max_speed)), float(rng.uniform(-cfg.max_turn_rate, cfg.max_turn_rate))
    carrot = tuple(rng.uniform(-2, 2, 2))

    def clearance(xy: np.ndarray) -> np.ndarray:
        return np.hypot(xy[..., 0] - obstacle[0], xy[..., 1] - obstacle[1])

    twist = dwa.choose(pose, v0, w0, carrot, 5.0, 0.6, clearance).twist
    assert abs(twist.v - v0) <= cfg.max_accel * 0.05 + 1e-9 or twist.v == 0.0 and v0 <= cfg.max_accel * 0.05
    assert abs(twist.omega - w0) <= cfg.max_yaw_accel * 0.05 + 1e-9
    x, y, yaw = pose  # integrate the chosen command finely over the horizon: it never comes within the radius
    for _ in range(int(cfg.horizon / 0.001)):
        x, y, yaw = x + twist.v * math.cos(yaw) * 0.001, y + twist.v * math.sin(yaw) * 0.001, yaw + twist.omega * 0.001
        assert math.hypot(x - obstacle[0], y - obstacle[1]) >= 0.2 - 0.005


def test_the_map_saves_as_a_ros_map_server_image() -> None:
    grid = OccupancyGrid((-3, -2), (3, 2), GridConfig(resolution=0.1), clearance_cap=0.5)
    grid.update(wall_scan((0.0, 0.0), 1.0))
    data = grid.to_pgm()
    magic, size, maxval, pixels = data.split(b"\n", 3)
    width, height = (int(v) for v in size.split())
    assert (magic, maxval, width, height) == (b"P5", b"255", 60, 40)
    img = np.frombuffer(pixels, dtype=np.uint8).reshape(height, width)

    def pixel(x: float, y: float) -> int:  # the top row is the largest y
        return int(img[height - 1 - math.floor((y + 2) / 0.1), math.floor((x + 3) / 0.1)])

    assert pixel(1.02, 0.33) == 0 and pixel(0.3, -0.4) == 254 and pixel(2.0, 0.0) == 205
    assert "resolution: 0.1\norigin: [-3.0000, -2.0000, 0.0]" in grid.map_yaml("map.pgm")
