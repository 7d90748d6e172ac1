"""``patrol_collect`` behaviour (lesson 08, project B): patrol waypoints, discover objects with the lidar, log
each one's estimated position once, drive to it, collect it, resume the patrol.

Objects are found only in the lidar scan (:mod:`robokit_behaviours.discovery`): returns that the known map does
not explain, in small clusters, fitted as circles. Body ids and true positions are never used to find or reach
anything. To report the localisation error, an optional ``truth_sensor`` (a ``body_pose`` sensor) is read when an
object is logged, and only into the result. Collection is the ``collector`` actuator (a front scoop, armed while
approaching); the patrol resumes towards the waypoint it left.

The goal (:meth:`PatrolCollect.check_goal`, on the world after the last tick): every waypoint visit made, every
collectable (a loose body the collector could take: movable, no joints, at most its ``max_mass``, not on the map)
stowed in the robot's bin, and no collision with the map. Anything else ends ``failed`` naming what is missing.
"""

from __future__ import annotations

import enum
import math
import statistics
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import Field
from robokit_behaviours.avoidance import MOTION_STATES
from robokit_behaviours.discovery import Discovery, DiscoveryConfig, Track
from robokit_behaviours.patrol import PATROL_TRANSITIONS, Patrol, PatrolConfig

from robokit import hookimpl
from robokit.components import GoalCheck, SetupContext
from robokit.errors import ConfigError
from robokit.msgs.mobile import STOP, Collect


class Phase(enum.Enum):
    """States of ``patrol_collect``."""

    TURNING = "turning"
    DRIVING = "driving"
    AVOIDING = "avoiding"
    APPROACHING = "approaching"
    DONE = "done"


TRANSITIONS: list[dict[str, Any]] = [
    *PATROL_TRANSITIONS,
    {"trigger": "spotted", "source": MOTION_STATES, "dest": "APPROACHING"},
    {"trigger": "collected", "source": "APPROACHING", "dest": "TURNING"},
    {"trigger": "lost", "source": "APPROACHING", "dest": "TURNING"},
]


BIN_RADIUS = 0.15
"""m: an object centre this close (xy) to the bin link, above it, is in the bin."""


class PatrolCollectConfig(PatrolConfig):
    """Config of ``patrol_collect`` (everything ``patrol`` takes, plus the following).

    Attributes:
        collector: Name of the ``collector`` actuator.
        truth_sensor: A ``body_pose`` sensor on the collectibles, read only to report localisation errors.
        approach_timeout: Sim seconds allowed to reach and collect one object before giving up on it.
        max_attempts: Approaches per object.
        discovery: Object discovery parameters.
    """

    collector: str = "collector"
    truth_sensor: str = ""
    approach_timeout: float = Field(30.0, gt=0)
    max_attempts: int = Field(2, ge=1)
    discovery: DiscoveryConfig = Field(default_factory=DiscoveryConfig)


class PatrolCollect(Patrol):
    """Patrol waypoints; find unknown objects on the lidar, log and collect each, resume (lesson 08B)."""
    COMMANDS: ClassVar[tuple[str, ...]] = ("drive", "collector")

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.TURNING

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg = self.config
        for key in ("collector", "truth_sensor"):
            name = getattr(cfg, key)
            if name and name not in ctx.components:
                raise ConfigError(f"no component named {name!r}; components: {', '.join(ctx.components)}", key=key)
        if not cfg.scan:
            raise ConfigError("patrol_collect discovers objects with a lidar: name one in 'scan'", key="scan")
        self.discovery = Discovery(cfg.discovery, [(b.lo, b.hi) for b in self.map])
        self.found: list[dict[str, Any]] = []
        self.target: Track | None = None
        self.approach_started = 0.0
        self.collected_count = 0
        self.scan_stamp = -1.0
        self.collectables = self._collectables(ctx)

    def _collectables(self, ctx: SetupContext) -> list[str]:
        """Ground truth for the goal: loose bodies the collector could take (not the robot, not on the map)."""
        collector = ctx.components.get(self.config.collector)
        limit = getattr(getattr(collector, "config", None), "max_mass", math.inf)
        robot = getattr(getattr(collector, "config", None), "robot", None)
        world, out = ctx.world, []
        for name in world.body_names:
            bid = world.body(name)
            mass = world.mass(bid)
            if name != robot and name not in self.map_names and not world.joints(bid) and 0.0 < mass <= limit:
                out.append(name)
        return out

    # ---------------------------------------------------------------- perception
    def _discover(self, readings: Mapping[str, Any], t: float) -> None:
        scan = readings[self.config.scan]
        if scan.stamp == self.scan_stamp:
            return
        self.scan_stamp = scan.stamp
        for track in self.discovery.update(scan):
            self._log(track, readings, t)

    def _log(self, track: Track, readings: Mapping[str, Any], t: float) -> None:
        """Log a newly found object once (estimate, world xy); add the truth for the report if configured."""
        entry: dict[str, Any] = {"id": track.id, "t": round(t, 3), "estimate": [round(v, 4) for v in track.xy]}
        entry.update(self._report_truth(readings, track.xy))
        self.found.append(entry)
        self.ctx.trace("object_found", id=track.id, estimate=entry["estimate"])

    def _report_truth(self, readings: Mapping[str, Any], est: tuple[float, float]) -> dict[str, Any]:
        """Reporting only: the true position of the object nearest to the estimate, and the error."""
        if not self.config.truth_sensor:
            return {}
        states = readings[self.config.truth_sensor]
        if not states:
            return {}
        name, state = min(states.items(), key=lambda kv: math.dist(kv[1].position[:2], est))
        true = state.position[:2]
        return {"true": [round(v, 4) for v in true], "body": name, "error": round(math.dist(true, est), 4)}

    # ---------------------------------------------------------------- states
    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        if self.outcome is None and self.state_name != "DONE":
            self._discover(readings, t)
        return super().step(readings, t)

    def _patrol(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        x, y, _ = self.pose(readings)
        target = self.discovery.nearest_pending(x, y, self.config.max_attempts)
        if target is not None:
            return self._start_approach(target, t)
        return super()._patrol(readings, t)

    do_turning = do_driving = do_avoiding = _patrol

    def _start_approach(self, target: Track, t: float) -> Mapping[str, Any]:
        self.target = target
        target.attempts += 1
        self.approach_started = t
        self.avoider.reset()
        self.fire("spotted")
        return {self.config.collector: Collect(True)}

    def do_approaching(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Drive at the target object with the scoop armed, until the collector reports a new object."""
        cfg, target = self.config, self.target
        assert target is not None
        state = readings[cfg.collector]
        if state.count > self.collected_count:
            self.collected_count = state.count
            taken = self.discovery.mark_collected(state.last_position or target.xy)
            self.ctx.trace("object_collected", id=taken.id if taken else None)
            return self._resume(t, "collected")
        if t - self.approach_started > cfg.approach_timeout:
            target.status = "found" if target.attempts < cfg.max_attempts else "abandoned"
            return self._resume(t, "lost")
        ignore = (target.x, target.y, cfg.discovery.object_radius + 0.12)
        nav = self.avoider.step(self.pose(readings), readings[cfg.scan], target.xy, t, ignore)
        return {cfg.drive: nav.twist}

    def _resume(self, t: float, trigger: str) -> Mapping[str, Any]:
        """Back to the patrol (or to the end of it) after an approach."""
        self.target = None
        self.avoider.reset()
        self.leg_started = t
        self.fire(trigger)
        out = {self.config.collector: Collect(False), self.config.drive: STOP}
        if self.leg >= self.legs_total:
            out.update(self.end_patrol(t) or {})
        return out

    def end_patrol(self, t: float) -> Mapping[str, Any] | None:
        """After the last waypoint, collect the objects already found, then finish."""
        x, y, _ = self.last.pose
        pending = self.discovery.nearest_pending(x, y, self.config.max_attempts)
        if pending is not None:
            return self._start_approach(pending, t)
        self.fire("finished")
        self.finish("failed" if self.missed else "succeeded", self._summary(t))
        return {self.config.drive: STOP, self.config.collector: Collect(False)}

    def _summary(self, t: float) -> str:
        return (f"{len(self.reached)}/{self.legs_total} waypoints, {len(self.found)} objects found, "
                f"{self.collected_count} collected, t = {t:.2f} s")

    def check_goal(self, world: Any) -> GoalCheck:
        """Every waypoint visited, every collectable in the robot's bin, no collision (ground truth)."""
        problems = []
        if self.missed:
            problems.append(f"missed {len(self.missed)} of {self.legs_total} waypoint visits")
        left = [n for n in self.collectables if not self._stowed(world, n)]
        if left:
            found = {f.get("body") for f in self.found}
            why = [f"{n} ({'found, not collected' if n in found else 'not collected'})" for n in left]
            problems.append(f"{len(left)} of {len(self.collectables)} object(s) not collected: {', '.join(why)}")
        if self.collisions:
            hit = sorted({c["body"] for c in self.collisions})
            problems.append(f"{len(self.collisions)} collision(s) with {', '.join(hit)}")
        details = {"collectables": len(self.collectables), "not_collected": left, "collisions": len(self.collisions)}
        if problems:
            return GoalCheck(False, "; ".join(problems), details)
        return GoalCheck(True, f"all {len(self.collectables)} object(s) collected, no collision", details)

    def _stowed(self, world: Any, name: str) -> bool:
        """True if a body rides in the robot's bin (world state): attached to the robot by a constraint, or
        resting within ``BIN_RADIUS`` of the bin link and above its floor."""
        cfg = getattr(self.ctx.components.get(self.config.collector), "config", None)
        if cfg is None or not world.has_body(name) or not world.has_body(cfg.robot):
            return False
        if world.joined(world.body(cfg.robot), world.body(name)):
            return True
        (bx, by, bz), _ = world.pose(cfg.robot, world.link(cfg.robot, cfg.bin_link))
        x, y, z = world.pose(name)[0]
        return math.hypot(x - bx, y - by) <= BIN_RADIUS and z > bz

    def result(self) -> dict[str, Any]:
        out = super().result()
        errors = [f["error"] for f in self.found if "error" in f]
        out.update({
            "objects_found": len(self.found),
            "objects_collected": self.collected_count,
            "found": self.found,
            "localisation_error_median": round(statistics.median(errors), 4) if errors else None,
        })
        return out


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("patrol_collect", PatrolCollect, PatrolCollectConfig)
