"""The planning navigator: occupancy grid + A* global path + dynamic-window local planner, step by step.

Each step (see :meth:`PlanningNavigator.step`):

1. A new scan is folded into the grid (:class:`~robokit.planning.grid.OccupancyGrid`).
2. The path is (re)planned with A* when there is none, when the goal changed, when a cell on the rest of the
   path became forbidden, when the robot has strayed from it, or every ``replan_period`` sim seconds.
3. The carrot is the point ``lookahead`` m further along the path than the point nearest the robot; the
   dynamic window (:class:`~robokit.planning.dwa.DynamicWindow`) picks ``(v, omega)`` towards it.

With no path (the goal walled off as far as the map knows) it returns ``None`` and the caller falls back to its
own rule.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.msgs.mobile import LaserScan, Pose2D, Twist, wrap_angle
from robokit.planning.dwa import DwaConfig, DynamicWindow
from robokit.planning.grid import GridConfig, OccupancyGrid
from robokit.planning.search import astar, shorten


class PlanningConfig(Schema):
    """Options of ``planner = "astar"``.

    Attributes:
        robot_radius: Radius of the disk the robot is modelled as, m (cells closer to an obstacle are forbidden).
        margin: Cells within this much more clearance cost extra in A*, m (the path keeps off walls)...
        penalty: ... up to ``1 + penalty`` times a step's length.
        known_map: Seed the grid with the static bodies standing above the floor (a known floor plan); the
            lidar still updates it.
        replan_period: Replan at least this often, sim seconds.
        stray_distance: Replan when the robot is further than this from its path, m.
        lookahead: The carrot is this far along the path, m.
        grid: Occupancy grid parameters.
        dwa: Local planner parameters.
    """

    robot_radius: float = Field(0.21, gt=0)
    margin: float = Field(0.3, ge=0)
    penalty: float = Field(3.0, ge=0)
    known_map: bool = False
    replan_period: float = Field(1.0, gt=0)
    stray_distance: float = Field(0.4, gt=0)
    lookahead: float = Field(0.6, gt=0)
    grid: GridConfig = Field(default_factory=GridConfig)  # type: ignore[arg-type]
    dwa: DwaConfig = Field(default_factory=DwaConfig)  # type: ignore[arg-type]


@dataclass
class PlanStats:
    """What the planner did: A* calls, their CPU time (s) and how many found a path."""

    plans: int = 0
    found: int = 0
    plan_seconds: float = 0.0
    grid_updates: int = 0
    reasons: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        return {"plans": self.plans, "found": self.found,
                "plan_ms_mean": round(1e3 * self.plan_seconds / max(self.plans, 1), 3),
                "grid_updates": self.grid_updates, "replan_reasons": dict(sorted(self.reasons.items()))}


MAX_LOGGED_PLANS = 2000
"""Paths kept for the run page; a long run replans every second or two."""


class PlanningNavigator:
    """Grid, global path and local planner for one robot (see the module docstring).

    Args:
        cfg: Planning options.
        lo: Lower corner of the mapped area ``(xmin, ymin)``, m, world frame.
        hi: Upper corner ``(xmax, ymax)``.
        period: Seconds between :meth:`step` calls (until two calls have measured it).
        boxes: Known-map boxes ``(xmin, ymin, xmax, ymax)`` to seed the grid with (``known_map``).
    """

    def __init__(self, cfg: PlanningConfig, lo: Sequence[float], hi: Sequence[float], period: float = 0.05,
                 boxes: Sequence[tuple[float, float, float, float]] = ()) -> None:
        self.cfg = cfg
        self.grid = OccupancyGrid(lo, hi, cfg.grid, clearance_cap=cfg.robot_radius + max(cfg.margin, cfg.dwa.soft)
                                  + cfg.grid.resolution)
        if boxes:
            self.grid.mark_boxes(boxes)
        self.dwa = DynamicWindow(cfg.dwa, cfg.robot_radius, period)
        self.stats = PlanStats()
        self.path: list[tuple[float, float]] = []
        self._cells: list[tuple[int, int]] = []
        self._goal: tuple[float, float] | None = None
        self._planned_at = -math.inf
        self._version = -1
        self._scan: LaserScan | None = None
        self._seg = 0
        self._last_t: float | None = None
        self._last_cmd: tuple[float, Twist] | None = None  # (sim time, command) of the last planned step
        self.plans: list[dict[str, object]] = []  # every path found: sim time, goal, waypoints (see plans_json)

    def plans_json(self) -> bytes:
        """Every path found, in order (at most ``MAX_LOGGED_PLANS``): ``{"plans": [{"t", "goal", "path"}]}``,
        times in sim s, points world xy in m. Saved beside the map as ``map_plans.json`` for the run page."""
        return json.dumps({"plans": self.plans}, separators=(",", ":")).encode()

    def reset(self) -> None:
        """Forget the path (a new goal follows)."""
        self.path, self._cells, self._goal, self._seg = [], [], None, 0

    # ---------------------------------------------------------------- global
    def plan(self, start: tuple[float, float], goal: tuple[float, float], tolerance: float) -> bool:
        """A* from ``start`` to ``goal`` (world xy, m) on the current grid; True if a path was found. A goal
        within an obstacle's reach is moved to the nearest allowed cell within ``tolerance``."""
        t0 = time.process_time()
        g = self.grid
        radius = self.cfg.robot_radius
        goal_cell = self._goal_cell(goal, tolerance)
        cells = None
        if goal_cell is not None:
            cells = astar(g.clearance, g.cell(*start), goal_cell, radius, g.res, self.cfg.margin, self.cfg.penalty)
        self.stats.plans += 1
        if cells is not None:
            self.stats.found += 1
            self._cells = cells
            short = shorten(g.clearance, cells, radius + self.cfg.margin / 2)
            self.path = [start, *[g.centre(i, j) for i, j in short[1:]]]
            if math.dist(self.path[-1], goal) <= tolerance * 0.5 or goal_cell == g.cell(*goal):
                self.path[-1] = goal
        else:
            self._cells, self.path = [], []
        self._seg = 0
        self.stats.plan_seconds += time.process_time() - t0
        return cells is not None

    def _goal_cell(self, goal: tuple[float, float], tolerance: float) -> tuple[int, int] | None:
        g = self.grid
        gi, gj = g.cell(*goal)
        if g.clearance[gi, gj] >= self.cfg.robot_radius:
            return gi, gj
        reach = max(1, int(tolerance / g.res))
        best, best_d = None, math.inf
        for i in range(max(0, gi - reach), min(g.shape[0], gi + reach + 1)):
            for j in range(max(0, gj - reach), min(g.shape[1], gj + reach + 1)):
                d = math.hypot(i - gi, j - gj) * g.res
                if d <= tolerance * 0.9 and d < best_d and g.clearance[i, j] >= self.cfg.robot_radius:
                    best, best_d = (i, j), d
        return best

    def _replan_reason(self, pose: Pose2D, goal: tuple[float, float], t: float) -> str | None:
        if goal != self._goal:
            return "goal"
        if not self.path:
            return "no path" if t - self._planned_at >= self.cfg.replan_period else None
        if self.grid.version != self._version:
            clear = self.grid.clearance
            if any(clear[i, j] < self.cfg.robot_radius for i, j in self._cells[1:]):
                return "blocked"
        if self._distance_to_path(pose) > self.cfg.stray_distance:
            return "strayed"
        if t - self._planned_at >= self.cfg.replan_period:
            return "period"
        return None

    # ---------------------------------------------------------------- local
    def _distance_to_path(self, pose: Pose2D) -> float:
        p = np.array(pose[:2])
        best = math.inf
        for a, b in zip(self.path[self._seg:], self.path[self._seg + 1:], strict=False):
            best = min(best, _point_segment(p, np.array(a), np.array(b))[0])
        return best if math.isfinite(best) else math.dist(pose[:2], self.path[-1])

    def carrot(self, pose: Pose2D) -> tuple[float, float]:
        """The point ``lookahead`` m along the path past the path point nearest the robot (world xy, m)."""
        path = self.path
        if len(path) == 1:
            return path[0]
        p = np.array(pose[:2])
        best, seg, along = math.inf, self._seg, 0.0
        for k in range(self._seg, min(len(path) - 1, self._seg + 3)):  # look at the next few segments only
            d, s = _point_segment(p, np.array(path[k]), np.array(path[k + 1]))
            if d < best - 1e-9:
                best, seg, along = d, k, s
        self._seg = seg
        left = self.cfg.lookahead
        a = np.array(path[seg]) + along * (np.array(path[seg + 1]) - np.array(path[seg]))
        k = seg + 1
        while k < len(path):
            b = np.array(path[k])
            step = float(np.hypot(*(b - a)))
            if step >= left:
                q = a + (b - a) * (left / step)
                return float(q[0]), float(q[1])
            left -= step
            a = b
            k += 1
        return path[-1]

    def step(self, pose: Pose2D, velocity: tuple[float, float], scan: LaserScan | None, goal: tuple[float, float],
             t: float, tolerance: float, ignore: tuple[float, float, float] | None = None
             ) -> tuple[Twist, float] | None:
        """One control step: the command and the heading error to the carrot (rad), or None with no path.

        Args:
            pose: Robot pose (x, y, yaw), world frame.
            velocity: Measured ``(v, omega)``, m/s and rad/s (the window starts from the last command instead
                when the previous step was planned too).
            scan: Latest scan (folded in once).
            goal: Target, world xy, m.
            t: Sim time, s.
            tolerance: The goal counts as reached within this distance, m.
            ignore: ``(x, y, radius)``: returns inside are not obstacles.
        """
        if self._last_t is not None and t > self._last_t:
            self.dwa.period = t - self._last_t  # the window is what the limits allow between two calls
        self._last_t = t
        if scan is not None and scan is not self._scan:
            self._scan = scan
            self.grid.update(scan, ignore)
            self.stats.grid_updates += 1
        reason = self._replan_reason(pose, goal, t)
        if reason is not None:
            self.stats.reasons[reason] = self.stats.reasons.get(reason, 0) + 1
            self._goal, self._planned_at, self._version = goal, t, self.grid.version
            if self.plan(pose[:2], goal, tolerance) and len(self.plans) < MAX_LOGGED_PLANS:
                self.plans.append({"t": round(t, 3), "goal": [round(v, 4) for v in goal],
                                   "path": [[round(x, 4), round(y, 4)] for x, y in self.path]})
        if not self.path:
            return None
        carrot = self.carrot(pose)
        dist = math.dist(pose[:2], goal)
        v0, w0 = velocity
        if self._last_cmd is not None and t - self._last_cmd[0] <= 1.5 * self.dwa.period:
            v0, w0 = self._last_cmd[1].v, self._last_cmd[1].omega  # the window moves from what was commanded
        choice = self.dwa.choose(pose, v0, w0, carrot, dist, self.cfg.lookahead, self.grid.clearance_at)
        error = wrap_angle(math.atan2(carrot[1] - pose[1], carrot[0] - pose[0]) - pose[2])
        self._last_cmd = (t, choice.twist)
        return choice.twist, error


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Distance from ``p`` to segment ``ab`` and the fraction along it of the nearest point."""
    ab = b - a
    denom = float(ab @ ab)
    s = 0.0 if denom < 1e-12 else float(np.clip((p - a) @ ab / denom, 0.0, 1.0))
    return float(np.hypot(*(p - a - s * ab))), s
