"""Lidar-driven navigation shared by ``go_to_goal``, ``patrol`` and ``patrol_collect``: a heading controller and
an obstacle avoider that gets around concave corners.

How it decides (every behaviour step, from the latest :class:`~robokit.msgs.mobile.LaserScan` and pose):

1. Scan hit points (world frame; floor returns dropped) are put in the robot frame. The robot is a disk of radius
   ``corridor``; for each of ``headings`` candidate directions the *clearance* is how far that disk can move
   before touching a point (:func:`clearances`).
2. If the goal direction is clear (up to the goal, or at least ``free_distance`` m) the robot heads for the goal.
3. Otherwise it *commits to a side* (counter-clockwise or clockwise: whichever free heading is nearer the goal
   direction) and then *follows the boundary*: it sweeps from the nearest obstacle point towards the committed side
   and takes the first free heading. Keeping the same side is what gets it out of a concave corner, where lesson
   07's "turn while blocked" turns back into the pocket forever. It leaves the boundary when the goal direction is
   clear for ``leave_distance`` m, or (Bug2's rule) when the goal is clear and it is closer to the goal than where
   it committed.
4. If the goal has not come 0.1 m closer for ``stall_time`` sim seconds it switches side (local-minimum escape).

The heading controller is smooth turn-then-drive: yaw rate proportional to the heading error, forward speed
scaled by ``cos(error)^2`` (zero beyond 90 degrees, so it turns in place first), by the clearance straight ahead
and by the distance left. Pure numpy: no pybullet here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from robokit.components import SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.mobile import STOP, LaserScan, Pose2D, Twist, wrap_angle
from robokit.planning import PlanningConfig, PlanningNavigator
from robokit.record.atomic import atomic_output


class AvoidanceConfig(Schema):
    """Navigation parameters (defaults fit the bundled diffbot). Lengths in m, speeds in m/s and rad/s.

    Attributes:
        max_speed: Top forward speed.
        max_turn_rate: Top yaw rate.
        heading_gain: Yaw rate per radian of heading error, 1/s.
        arrive_gain: Forward speed per metre left to the goal, 1/s (smooth arrival).
        corridor: Radius of the disk the robot is modelled as (half-diagonal + margin); clearances are how far
            that disk can move along a heading before touching a scan point.
        stop_distance: Stop driving forward when the clearance straight ahead is this small.
        slow_distance: Start slowing down when the clearance straight ahead is this small.
        free_distance: A heading is free when its clearance is at least this (or reaches the goal).
        leave_distance: Stop following a boundary as soon as the goal direction is clear this far (or to the goal).
        follow_gap: Extra margin kept from a boundary while following or choosing a side.
        follow_range: While following, the boundary is the nearest scan point within this distance.
        ground_height: Scan points lower than this (m, world z) are floor returns, not obstacles.
        headings: Candidate headings over the full circle.
        stall_time: Sim seconds without getting 0.1 m closer to the goal before switching side.
        leave_margin: Leave the boundary only this much closer to the goal than where it was met.
    """

    max_speed: float = Field(0.4, gt=0)
    max_turn_rate: float = Field(1.5, gt=0)
    heading_gain: float = Field(2.5, gt=0)
    arrive_gain: float = Field(1.0, gt=0)
    corridor: float = Field(0.26, gt=0)
    stop_distance: float = Field(0.03, ge=0)
    slow_distance: float = Field(0.5, gt=0)
    free_distance: float = Field(0.7, gt=0)
    leave_distance: float = Field(2.0, gt=0)
    follow_gap: float = Field(0.12, ge=0)
    follow_range: float = Field(1.0, gt=0)
    ground_height: float = Field(0.03, ge=0)
    headings: int = Field(72, ge=8, le=720)
    stall_time: float = Field(20.0, gt=0)
    leave_margin: float = Field(0.05, ge=0)


def track_heading(error: float, dist: float, clear_ahead: float, cfg: AvoidanceConfig) -> Twist:
    """Smooth turn-then-drive command towards a heading ``error`` (rad) with ``dist`` m left to go.

    Forward speed falls with ``cos(error)^2`` (zero beyond 90 degrees: turn in place first), with the clearance
    straight ahead (``clear_ahead``, m, see :func:`clearances`) and with the distance left.
    """
    omega = float(min(max(cfg.heading_gain * error, -cfg.max_turn_rate), cfg.max_turn_rate))
    align = math.cos(error) ** 2 if abs(error) < math.pi / 2 else 0.0
    room = (clear_ahead - cfg.stop_distance) / max(cfg.slow_distance - cfg.stop_distance, 1e-6)
    v = cfg.max_speed * align * float(min(max(room, 0.0), 1.0))
    v = min(v, cfg.arrive_gain * dist + 0.03)
    return Twist(v, omega)


def to_robot_frame(points: np.ndarray, pose: Pose2D) -> np.ndarray:
    """World-frame xy points (n, 2) into the robot frame of ``pose`` = (x, y, yaw)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    d = points - np.array([x, y])
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def clearances(points: np.ndarray, angles: np.ndarray, corridor: float, far: float) -> np.ndarray:
    """Free distance (m) along each heading in ``angles`` (robot frame) before a point enters the corridor.

    Args:
        points: Obstacle points in the robot frame, (n, 2), m.
        angles: Headings, rad, robot frame.
        corridor: Corridor half-width, m.
        far: Value for headings with nothing in the way, m.
    """
    if len(points) == 0:
        return np.full(len(angles), far)
    u = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    along = points @ u.T
    lateral = np.abs(points[:, 0:1] * u[:, 1] - points[:, 1:2] * u[:, 0])
    ahead = (lateral < corridor) & (along > 0.0)  # points behind never block a heading that moves away
    dist = np.where(ahead, np.maximum(along - np.sqrt(np.maximum(corridor**2 - lateral**2, 0.0)), 0.0), far)
    return np.asarray(dist.min(axis=0))


@dataclass
class NavStep:
    """What the navigator decided: the command, whether it is following an obstacle, and the goal geometry."""

    twist: Twist
    avoiding: bool
    distance: float
    heading_error: float


class Avoider:
    """Goal-seeking obstacle avoidance on a laser scan (see the module docstring). One instance per behaviour."""

    def __init__(self, cfg: AvoidanceConfig) -> None:
        self.cfg = cfg
        self.angles = -math.pi + (2.0 * math.pi / cfg.headings) * np.arange(cfg.headings)
        self._scan: LaserScan | None = None  # the last scan filtered by _points, with its ignore circle and result
        self._ignore: tuple[float, float, float] | None = None
        self._world_points = np.zeros((0, 2))
        self.reset()

    def reset(self) -> None:
        """Forget the committed side and progress (call when the goal changes)."""
        self.side = 0
        self.commit_distance = math.inf
        self.best = math.inf
        self.best_at = 0.0
        self.switches = 0

    def step(self, pose: Pose2D, scan: LaserScan | None, goal: tuple[float, float], t: float,
             ignore: tuple[float, float, float] | None = None) -> NavStep:
        """One decision towards ``goal`` (world xy, m) at sim time ``t`` (s).

        Args:
            pose: Robot pose (x, y, yaw), world frame.
            scan: Latest scan (``None``: no lidar, plain go-to-goal).
            goal: Target point, world frame, m.
            t: Sim time, s.
            ignore: ``(x, y, radius)``: scan points within that circle are not obstacles (the object being
                collected).
        """
        dx, dy = goal[0] - pose[0], goal[1] - pose[1]
        dist = math.hypot(dx, dy)
        bearing = wrap_angle(math.atan2(dy, dx) - pose[2])
        points = self._points(pose, scan, ignore)
        far = scan.range_max if scan is not None else 1e3
        self._watch_progress(dist, t)
        goal_clear, ahead = (float(v) for v in clearances(points, np.array([bearing, 0.0]), self.cfg.corridor, far))
        if self.side != 0 and self._may_leave(goal_clear, dist):
            self.side = 0
        if self.side == 0 and goal_clear >= min(dist, self.cfg.free_distance):
            heading = bearing
        elif self.side == 0:
            heading = self._commit(points, bearing, dist, far)
        else:
            heading = self._follow(points, bearing, far)
        twist = track_heading(wrap_angle(heading), dist, ahead, self.cfg)
        return NavStep(twist, self.side != 0, dist, bearing)

    def _may_leave(self, goal_clear: float, dist: float) -> bool:
        """Bug2's leave rule (goal clear and closer than where the boundary was met), or a long clear view."""
        if goal_clear >= min(dist, self.cfg.leave_distance):
            return True
        closer = dist < self.commit_distance - self.cfg.leave_margin
        return closer and goal_clear >= min(dist, self.cfg.free_distance)

    def _free(self, points: np.ndarray, far: float) -> tuple[np.ndarray, np.ndarray]:
        clear = clearances(points, self.angles, self.cfg.corridor + self.cfg.follow_gap, far)
        return clear, clear >= self.cfg.free_distance

    def _commit(self, points: np.ndarray, bearing: float, dist: float, far: float) -> float:
        """Choose the side whose free heading is nearer the goal direction; return that heading (robot frame)."""
        clear, free = self._free(points, far)
        if not free.any():
            return float(self.angles[int(np.argmax(clear))])
        offsets = (self.angles - bearing) % (2.0 * math.pi)  # counter-clockwise offset from the goal direction
        ccw = np.where(free, offsets, np.inf)
        cw = np.where(free, 2.0 * math.pi - offsets, np.inf)
        self.side = 1 if ccw.min() <= cw.min() else -1
        self.commit_distance = dist
        return float(self.angles[int(np.argmin(ccw if self.side > 0 else cw))])

    def _follow(self, points: np.ndarray, bearing: float, far: float) -> float:
        """Boundary following: sweep from the nearest obstacle point towards the committed side; the first free
        heading wins. With no obstacle within ``follow_range`` the sweep starts at the goal direction."""
        clear, free = self._free(points, far)
        if not free.any():
            return float(self.angles[int(np.argmax(clear))])
        start = bearing
        if len(points):
            near = np.hypot(points[:, 0], points[:, 1])
            i = int(np.argmin(near))
            if near[i] < self.cfg.follow_range:
                start = math.atan2(points[i, 1], points[i, 0])
        offsets = ((self.angles - start) * self.side) % (2.0 * math.pi)
        return float(self.angles[int(np.argmin(np.where(free, offsets, np.inf)))])

    def _points(self, pose: Pose2D, scan: LaserScan | None, ignore: tuple[float, float, float] | None) -> np.ndarray:
        """Scan hit points in the robot frame, (n, 2), without those inside the ``ignore`` circle."""
        if scan is None:
            return np.zeros((0, 2))
        if scan is not self._scan or ignore != self._ignore:  # a 10 Hz scan serves two 20 Hz steps: filter it once
            hits = scan.points[scan.hits]
            pts = hits[hits[:, 2] > self.cfg.ground_height, :2]  # a tilted scan plane reaching the floor is no wall
            if ignore is not None and len(pts):
                keep = np.hypot(pts[:, 0] - ignore[0], pts[:, 1] - ignore[1]) > ignore[2]
                pts = pts[keep]
            self._scan, self._ignore, self._world_points = scan, ignore, pts
        return to_robot_frame(self._world_points, pose)

    def _watch_progress(self, dist: float, t: float) -> None:
        """Switch side when the goal has not come 0.1 m closer for ``stall_time`` seconds."""
        if dist < self.best - 0.1:
            self.best, self.best_at = dist, t
        elif t - self.best_at > self.cfg.stall_time:
            if self.side != 0:
                self.side = -self.side
                self.commit_distance = dist
                self.switches += 1
            self.best, self.best_at = dist, t


MOTION_STATES = ["TURNING", "DRIVING", "AVOIDING"]
MOTION_TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "aligned", "source": "TURNING", "dest": "DRIVING"},
    {"trigger": "misaligned", "source": "DRIVING", "dest": "TURNING"},
    {"trigger": "blocked", "source": ["TURNING", "DRIVING"], "dest": "AVOIDING"},
    {"trigger": "clear", "source": "AVOIDING", "dest": "TURNING"},
]
"""Transitions shared by every navigating machine: turn to the goal, drive, go around obstacles."""


class NavConfig(Schema):
    """Options every navigating behaviour shares.

    Attributes:
        drive: Name of the ``diff_drive`` actuator.
        scan: Name of the ``lidar`` sensor (empty: no obstacle avoidance).
        tolerance: A goal is reached within this distance, m.
        align_deg: Turning in place ends when the heading error is below this, degrees.
        avoidance: Navigation parameters.
        planner: ``"rules"``: steer by the clearance rules of :class:`Avoider`; ``"astar"``: an occupancy grid
            from the lidar, A* over it and a dynamic-window local planner (:mod:`robokit.planning`), the rules
            only while the map shows no way to the goal.
        planning: Parameters of ``planner = "astar"``.
    """

    drive: str = "drive"
    scan: str = "scan"
    tolerance: float = Field(0.2, gt=0)
    align_deg: float = Field(20.0, gt=0, lt=90)
    avoidance: AvoidanceConfig = Field(default_factory=AvoidanceConfig)  # type: ignore[arg-type]
    planner: Literal["rules", "astar"] = "rules"
    planning: PlanningConfig = Field(default_factory=PlanningConfig)  # type: ignore[arg-type]


MAX_RAY_SPACING_DEG = 10.0
"""The avoider needs a ray at least every this many degrees: a can 10 cm wide, seen at the 0.5 m where it must
start slowing down, spans about 11 degrees."""
MIN_FOV_DEG = 180.0
"""... over at least the half circle ahead."""


def check_scan(lidar: Any, name: str) -> None:
    """Refuse a lidar too coarse for obstacle avoidance (a ConfigError at ``scan``); other types pass unchecked."""
    cfg = getattr(lidar, "config", None)
    rays, fov = getattr(cfg, "rays", None), getattr(cfg, "fov_deg", None)
    if not isinstance(rays, int) or not isinstance(fov, (int, float)):
        return
    spacing = fov / (rays if fov >= 360.0 else max(rays - 1, 1)) if rays > 1 else 360.0
    if rays < 2 or spacing > MAX_RAY_SPACING_DEG or fov < MIN_FOV_DEG:
        raise ConfigError(
            f"lidar {name!r} has {rays} ray(s) over {fov:g} deg (one every {spacing:g} deg): obstacle avoidance "
            f"needs a ray at least every {MAX_RAY_SPACING_DEG:g} deg over at least {MIN_FOV_DEG:g} deg; raise its "
            f"'rays' (e.g. rays = {math.ceil(max(fov, MIN_FOV_DEG) / MAX_RAY_SPACING_DEG) + 1})", key="scan")


class Navigating:
    """Mixin for :class:`robokit.fsm.MachineBehaviour` subclasses whose machines include ``MOTION_TRANSITIONS``.

    :meth:`move_towards` runs the avoider and fires the motion triggers when the situation changes.
    """
    COMMANDS: ClassVar[tuple[str, ...]] = ("drive",)
    """The config fields naming the actuators it commands (``robokit validate`` checks who commands what)."""

    config: Any
    state_name: str
    fire: Callable[[str], bool]  # provided by MachineBehaviour

    def setup_navigation(self, ctx: SetupContext) -> None:
        """Check that the drive (and scan, if named) exist; build the avoider. Call from ``setup``."""
        cfg = self.config
        for key in ("drive", "scan"):
            name = getattr(cfg, key)
            if name and name not in ctx.components:
                raise ConfigError(
                    f"no component named {name!r}; components: {', '.join(ctx.components) or '(none)'}", key=key
                )
        if cfg.scan:
            check_scan(ctx.components[cfg.scan], cfg.scan)
        self.avoider = Avoider(cfg.avoidance)
        self.planner: PlanningNavigator | None = None
        if cfg.planner == "astar":
            if not cfg.scan and not cfg.planning.known_map:
                raise ConfigError("planner 'astar' needs a lidar ('scan') or planning.known_map = true", key="planner")
            self.planner = build_planner(ctx, cfg)

    def planning_result(self) -> dict[str, Any]:
        """The planner's counts for the run's result (empty with the rules)."""
        if self.planner is None:
            return {}
        return {"planner": "astar", "planning": self.planner.stats.as_dict()}

    def close(self) -> None:
        """At the end of a run that keeps a record: the planner's map as ``map.pgm`` + ``map.yaml`` (ROS
        ``map_server``'s format) and the paths it planned (``map_plans.json``) in the run folder."""
        run_dir = getattr(getattr(self, "ctx", None), "run_dir", None)
        planner = getattr(self, "planner", None)
        if planner is not None and run_dir is not None and Path(run_dir).is_dir():
            grid = planner.grid
            for name, data in (("map.pgm", grid.to_pgm()), ("map.yaml", grid.map_yaml("map.pgm").encode()),
                               ("map_plans.json", planner.plans_json())):
                with atomic_output(Path(run_dir) / name) as tmp:
                    tmp.write_bytes(data)
        parent = getattr(super(), "close", None)
        if parent is not None:
            parent()

    def halt(self, t: float) -> Mapping[str, Any] | None:
        """Stopped before it ended (a composite's timeout, a monitor): the drive stops; never stepped again."""
        return {self.config.drive: STOP}

    def pose(self, readings: Mapping[str, Any]) -> Pose2D:
        """The robot's pose from the drive reading."""
        return readings[self.config.drive].pose  # type: ignore[no-any-return]

    def move_towards(self, readings: Mapping[str, Any], goal: tuple[float, float], t: float,
                     ignore: tuple[float, float, float] | None = None) -> NavStep:
        """One navigation step towards ``goal`` (world xy, m); fires aligned / misaligned / blocked / clear."""
        scan = readings[self.config.scan] if self.config.scan else None
        nav = None
        planned = False
        if self.planner is not None:
            drive = readings[self.config.drive]
            step = self.planner.step(drive.pose, (drive.v, drive.omega), scan, goal, t, self.config.tolerance,
                                     ignore)
            if step is not None:
                x, y, _ = drive.pose
                nav = NavStep(step[0], False, math.hypot(goal[0] - x, goal[1] - y), step[1])
                planned = True
        if nav is None:
            nav = self.avoider.step(self.pose(readings), scan, goal, t, ignore)
        align = math.radians(self.config.align_deg)
        state = self.state_name
        if nav.avoiding and state != "AVOIDING" and state in MOTION_STATES:
            self.fire("blocked")
        elif not nav.avoiding and state == "AVOIDING":
            self.fire("clear")
        elif state == "TURNING" and abs(nav.heading_error) < align:
            self.fire("aligned")
        elif state == "DRIVING" and abs(nav.heading_error) > 2.5 * align and nav.distance > self.config.tolerance:
            self.fire("misaligned")
        if self.state_name == "TURNING" and not planned:
            nav.twist = Twist(0.0, nav.twist.omega)  # the rules turn in place; the local planner's command stands
        return nav


def build_planner(ctx: SetupContext, cfg: NavConfig) -> PlanningNavigator:
    """A :class:`~robokit.planning.PlanningNavigator` over the area the run can reach: the robot's start, the
    config's goal and waypoints and the static bodies standing above the floor, plus ``planning.grid.margin``
    (or ``planning.grid.extent``). With ``planning.known_map`` the grid starts with those bodies marked."""
    world = ctx.world
    p = cfg.planning
    statics = []
    for name in world.body_names:
        lo, hi = world.body_aabb(name)
        if world.mass(name) == 0 and hi[2] > 0.02 and max(abs(v) for v in (*lo[:2], *hi[:2])) < 1e3:
            statics.append((lo[0], lo[1], hi[0], hi[1]))
    if p.grid.extent:
        if len(p.grid.extent) != 4 or p.grid.extent[0] >= p.grid.extent[2] or p.grid.extent[1] >= p.grid.extent[3]:
            raise ConfigError(f"expected (xmin, ymin, xmax, ymax), got {list(p.grid.extent)}",
                              key="planning.grid.extent")
        lo2, hi2 = p.grid.extent[:2], p.grid.extent[2:]
    else:
        robot = getattr(getattr(ctx.components.get(cfg.drive), "config", None), "robot", None)
        xs: list[float] = []
        ys: list[float] = []
        if robot and world.has_body(robot):
            start = world.pose(robot)[0]
            xs.append(start[0])
            ys.append(start[1])
        for point in (getattr(cfg, "goal", None), *getattr(cfg, "waypoints", ())):
            if point is not None:
                xs.append(point[0])
                ys.append(point[1])
        for x0, y0, x1, y1 in statics:
            xs += [x0, x1]
            ys += [y0, y1]
        m = p.grid.margin
        lo2, hi2 = (min(xs) - m, min(ys) - m), (max(xs) + m, max(ys) + m)
    planner = PlanningNavigator(p, lo2, hi2, boxes=statics if p.known_map else ())
    drive_cfg = getattr(ctx.components.get(cfg.drive), "config", None)
    rim = getattr(drive_cfg, "max_acceleration", None)
    track = getattr(drive_cfg, "track_width", None)
    if isinstance(rim, (int, float)) and isinstance(track, (int, float)):  # the window never asks more than the drive
        planner.dwa.cfg = p.dwa.model_copy(update={"max_accel": min(p.dwa.max_accel, rim),
                                                   "max_yaw_accel": min(p.dwa.max_yaw_accel, 2 * rim / track)})
    return planner
