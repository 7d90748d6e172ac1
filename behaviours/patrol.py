"""``patrol`` behaviour (lesson 07's exercise): visit waypoints in order, A -> B -> C -> A, for N laps.

Each leg is driven with the shared navigator (turn, drive, go around obstacles on the lidar scan). A waypoint not
reached within ``waypoint_timeout`` sim seconds is skipped and recorded as missed. The known map (the static
obstacles and walls: ``map_bodies``, or every static body standing above the floor) is read once at setup as
axis-aligned boxes; a waypoint inside one (grown by ``robot_radius``) is a config error. Collisions are counted
as the robot starting to touch a map body (from a ``contact`` sensor on the robot, or the drive's own contact
list when no sensor is named). Succeeds when every waypoint of every lap was reached.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import Field
from robokit_behaviours.avoidance import MOTION_STATES, MOTION_TRANSITIONS, NavConfig, Navigating

from robokit import hookimpl
from robokit.components import SetupContext
from robokit.config import Vec2
from robokit.errors import ConfigError
from robokit.fsm import MachineBehaviour
from robokit.msgs.mobile import STOP


class Phase(enum.Enum):
    """States of ``patrol``."""

    TURNING = "turning"
    DRIVING = "driving"
    AVOIDING = "avoiding"
    DONE = "done"


PATROL_TRANSITIONS: list[dict[str, Any]] = [
    *MOTION_TRANSITIONS,
    {"trigger": "reached", "source": MOTION_STATES, "dest": "TURNING"},
    {"trigger": "skipped", "source": MOTION_STATES, "dest": "TURNING"},
    {"trigger": "finished", "source": MOTION_STATES, "dest": "DONE"},
]


class PatrolConfig(NavConfig):
    """Config of ``patrol``.

    Attributes:
        waypoints: Points to visit in order, (x, y) m, world frame.
        laps: Times to go round.
        waypoint_timeout: Sim seconds allowed per leg before the waypoint is skipped.
        map_bodies: Bodies that make up the known map (empty: every static body standing above the floor).
        robot_radius: A waypoint closer than this to a map box is inside it, m.
        contact_sensor: A ``contact`` sensor on the robot for collision counting (empty: the drive's contacts).
    """

    waypoints: tuple[Vec2, ...] = Field(min_length=1)
    laps: int = Field(1, ge=1)
    waypoint_timeout: float = Field(90.0, gt=0)
    map_bodies: tuple[str, ...] = ()
    robot_radius: float = Field(0.2, ge=0)
    contact_sensor: str = ""


@dataclass(frozen=True)
class MapBox:
    """One box of the known map: name and xy footprint ``(xmin, ymin, xmax, ymax)``, m, world frame."""

    name: str
    lo: tuple[float, float]
    hi: tuple[float, float]

    def contains(self, x: float, y: float, grow: float = 0.0) -> bool:
        """True if (x, y) is inside the footprint grown by ``grow`` metres."""
        return self.lo[0] - grow <= x <= self.hi[0] + grow and self.lo[1] - grow <= y <= self.hi[1] + grow


def known_map(ctx: SetupContext, names: tuple[str, ...], key: str = "map_bodies") -> list[MapBox]:
    """The known map as boxes: the named bodies, or every static body standing above the floor.

    Read once at setup: the map is given, like the floor plan a real patrol robot is handed.
    """
    world = ctx.world
    for i, name in enumerate(names):
        if not world.has_body(name):
            raise ConfigError(f"unknown body {name!r}; bodies: {', '.join(world.body_names)}", key=f"{key}[{i}]")
    if not names:
        names = tuple(n for n in world.body_names if world.mass(n) == 0
                      and world.body_aabb(n)[1][2] > 0.02)
    boxes = []
    for name in names:
        lo, hi = world.body_aabb(name)
        boxes.append(MapBox(name, (lo[0], lo[1]), (hi[0], hi[1])))
    return boxes


def world_bounds(ctx: SetupContext, boxes: list[MapBox], drive: str) -> tuple[str, MapBox] | None:
    """The area the robot can be in (xy, world): the map's extent when it encloses the robot's start (a walled
    arena), else the floor's (static bodies lying flat on the ground), if finite. None when there is no bound."""
    world = ctx.world
    robot = getattr(getattr(ctx.components.get(drive), "config", None), "robot", None)
    start = world.pose(robot)[0] if robot and world.has_body(robot) else None
    if boxes and start is not None:
        extent = MapBox("map", (min(b.lo[0] for b in boxes), min(b.lo[1] for b in boxes)),
                        (max(b.hi[0] for b in boxes), max(b.hi[1] for b in boxes)))
        if extent.contains(start[0], start[1]):
            return "the map's extent", extent
    floors = []
    for name in world.body_names:
        lo, hi = world.body_aabb(name)
        if hi[2] <= 0.05 and world.mass(name) == 0:
            floors.append(MapBox(name, (lo[0], lo[1]), (hi[0], hi[1])))
    finite = [f for f in floors if max(abs(v) for v in (*f.lo, *f.hi)) < 1e3]
    if not finite or len(finite) != len(floors):
        return None
    return "the floor", MapBox("floor", (min(f.lo[0] for f in finite), min(f.lo[1] for f in finite)),
                               (max(f.hi[0] for f in finite), max(f.hi[1] for f in finite)))


def point_problems(ctx: SetupContext, points: list[tuple[str, Vec2]], boxes: list[MapBox], drive: str,
                   grow: float) -> list[ConfigError]:
    """Problems for goal points (``key``, (x, y)) outside the world's bounds or inside a map box grown by ``grow``."""
    problems = []
    bounds = world_bounds(ctx, boxes, drive)
    for key, (x, y) in points:
        if bounds is not None and not bounds[1].contains(x, y):
            b = bounds[1]
            problems.append(ctx.problem(f"({x:g}, {y:g}) is outside {bounds[0]} (x {b.lo[0]:.2f}..{b.hi[0]:.2f}, "
                                        f"y {b.lo[1]:.2f}..{b.hi[1]:.2f})", key))
            continue
        for box in boxes:
            if box.contains(x, y, grow):
                problems.append(ctx.problem(f"({x:g}, {y:g}) is inside obstacle {box.name!r} (grown by {grow:g} m)",
                                            key))
                break
    return problems


class Patrol(Navigating, MachineBehaviour):
    """Visit waypoints in order for N laps, going around obstacles (lesson 07's A -> B -> C -> A)."""

    STATES = Phase
    TRANSITIONS = PATROL_TRANSITIONS
    INITIAL = Phase.TURNING

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.setup_navigation(ctx)
        cfg = self.config
        if cfg.contact_sensor and cfg.contact_sensor not in ctx.components:
            raise ConfigError(f"no sensor named {cfg.contact_sensor!r}", key="contact_sensor")
        self.map = known_map(ctx, cfg.map_bodies)
        for i, (x, y) in enumerate(cfg.waypoints):
            for box in self.map:
                if box.contains(x, y, cfg.robot_radius):
                    raise ConfigError(
                        f"waypoint ({x:g}, {y:g}) is inside obstacle {box.name!r} (x {box.lo[0]:.2f}..{box.hi[0]:.2f}, "
                        f"y {box.lo[1]:.2f}..{box.hi[1]:.2f}, grown by robot_radius {cfg.robot_radius:g} m)",
                        key=f"waypoints[{i}]")
        self.map_names = {b.name for b in self.map}
        self.leg = 0
        self.leg_started: float | None = None  # sim time the current leg began (the first: the first step)
        self.reached: list[dict[str, Any]] = []
        self.missed: list[dict[str, Any]] = []
        self.touching: set[str] = set()
        self.collisions: list[dict[str, Any]] = []
        self.last: Any = None

    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Every waypoint lies inside the world's bounds (see :func:`world_bounds`)."""
        cfg = self.config
        points = [(f"waypoints[{i}]", wp) for i, wp in enumerate(cfg.waypoints)]
        return point_problems(ctx, points, self.map, cfg.drive, cfg.robot_radius)

    # ---------------------------------------------------------------- bookkeeping
    @property
    def goal(self) -> tuple[float, float]:
        """The current waypoint, world xy, m."""
        wps = self.config.waypoints
        return wps[self.leg % len(wps)]

    @property
    def legs_total(self) -> int:
        """Waypoint visits in the whole patrol."""
        return len(self.config.waypoints) * self.config.laps

    def count_collisions(self, readings: Mapping[str, Any], t: float) -> None:
        """Count each new contact with a map body as one collision."""
        cfg = self.config
        if cfg.contact_sensor:
            names = set(getattr(readings[cfg.contact_sensor], "others", ()))
        else:
            names = set(readings[cfg.drive].contacts)
        names &= self.map_names
        for name in sorted(names - self.touching):
            self.collisions.append({"t": round(t, 3), "body": name})
            self.ctx.trace("collision", body=name)
        self.touching = names

    def next_leg(self, t: float, reached: bool) -> Mapping[str, Any] | None:
        """Record the leg's end and go on to the next waypoint (or finish)."""
        entry = {"waypoint": self.leg % len(self.config.waypoints), "lap": self.leg // len(self.config.waypoints),
                 "t": round(t, 3)}
        (self.reached if reached else self.missed).append(entry)
        self.ctx.trace("waypoint_reached" if reached else "waypoint_missed", **entry)
        self.leg += 1
        self.leg_started = t
        self.avoider.reset()
        if self.leg >= self.legs_total:
            return self.end_patrol(t)
        self.fire("reached" if reached else "skipped")
        return None

    def end_patrol(self, t: float) -> Mapping[str, Any] | None:
        """All legs done: finish (succeeded only if no waypoint was missed) and stop."""
        self.fire("finished")
        if self.missed:
            self.finish("failed", f"missed {len(self.missed)} of {self.legs_total} waypoint visits")
        else:
            self.finish("succeeded", f"visited all {self.legs_total} waypoints at t = {t:.2f} s")
        return {self.config.drive: STOP}

    # ---------------------------------------------------------------- states
    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        self.last = readings[self.config.drive]
        if self.leg_started is None:
            self.leg_started = t
        self.count_collisions(readings, t)
        return super().step(readings, t)

    def _patrol(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        nav = self.move_towards(readings, self.goal, t)
        if nav.distance <= self.config.tolerance:
            return self.next_leg(t, reached=True) or {self.config.drive: nav.twist}
        if t - (self.leg_started or 0.0) > self.config.waypoint_timeout:
            return self.next_leg(t, reached=False) or {self.config.drive: nav.twist}
        return {self.config.drive: nav.twist}

    do_turning = do_driving = do_avoiding = _patrol

    def result(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "waypoints_total": self.legs_total,
            "waypoints_reached": len(self.reached),
            "waypoints_missed": len(self.missed),
            "visits": self.reached,
            "collisions": len(self.collisions),
            "collision_events": self.collisions,
            "sim_time": round(self.t, 3),
        }
        if self.last is not None:
            out["distance_travelled"] = round(self.last.distance, 3)
        out.update(self.planning_result())
        return out


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("patrol", Patrol, PatrolConfig)
