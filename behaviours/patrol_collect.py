"""``patrol_collect`` behaviour (lesson 08, project B): patrol waypoints, discover objects with the lidar, log
each one's estimated position once, drive to it, collect it, resume the patrol.

Objects are found only in the lidar scan (:mod:`robokit_behaviours.discovery`): returns that the known map does
not explain, in small clusters, fitted as circles. Body ids and true positions are never used to find or reach
anything. To report the localisation error, an optional ``truth_sensor`` (a ``body_pose`` sensor) is read when an
object is logged, and only into the result. Two ways to collect, chosen by config:

- ``gripper`` + ``lift`` + ``bin`` (a robot with a gripper on a lift, e.g. the bundled collectbot): drive up until
  the object sits between the open fingers, close them, lift, carry it to the ``bin`` (an area on the floor with a
  mouth), drive straight in, lower it, let go and back out. The object moves only by contacts. The goal asks the
  world whether every collectable lies inside the bin's area, resting on the floor.
- ``collector`` (the ``collector`` actuator): a scripted stow. When the object is within the scoop's reach zone the
  simulator switches its collisions off and fixes it on the robot's bin link: it is moved by the program, not by
  contacts. It stands in for a mechanism on robots that have none (the plain diffbot).

The patrol resumes towards the waypoint it left. The goal (:meth:`PatrolCollect.check_goal`, on the world after the
last tick): every waypoint visit made, every collectable (a loose body: movable, no joints, not on the map, with the
stow at most the collector's ``max_mass``) in the bin, and no collision with the map. Anything else ends
``failed`` naming what is missing.
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
from robokit.msgs.arm import GripperCommand, JointCommand
from robokit.msgs.mobile import STOP, Collect, Twist
from robokit.planning.dock import Bin, BinConfig


class Phase(enum.Enum):
    """States of ``patrol_collect``."""

    TURNING = "turning"
    DRIVING = "driving"
    AVOIDING = "avoiding"
    APPROACHING = "approaching"
    GRASPING = "grasping"
    CARRYING = "carrying"
    DOCKING = "docking"
    RELEASING = "releasing"
    LEAVING = "leaving"
    DONE = "done"


TRANSITIONS: list[dict[str, Any]] = [
    *PATROL_TRANSITIONS,
    {"trigger": "spotted", "source": MOTION_STATES, "dest": "APPROACHING"},
    {"trigger": "collected", "source": "APPROACHING", "dest": "TURNING"},
    {"trigger": "lost", "source": ["APPROACHING", "GRASPING"], "dest": "TURNING"},
    {"trigger": "within_reach", "source": "APPROACHING", "dest": "GRASPING"},
    {"trigger": "lifted", "source": "GRASPING", "dest": "CARRYING"},
    {"trigger": "at_bin", "source": "CARRYING", "dest": "DOCKING"},
    {"trigger": "over_slot", "source": "DOCKING", "dest": "RELEASING"},
    {"trigger": "released", "source": "RELEASING", "dest": "LEAVING"},
    {"trigger": "delivered", "source": "LEAVING", "dest": "TURNING"},
    {"trigger": "dropped", "source": ["CARRYING", "DOCKING"], "dest": "TURNING"},
]


BIN_RADIUS = 0.15
"""m: an object centre this close (xy) to the bin link, above it, is in the robot's bin (the scripted stow)."""
RELEASE_HEIGHT = 0.0
"""m: the lift's position when the object is set down in the bin (standing on the floor)."""
SOFT_GRIP = 0.5
"""N: the finger force while the fingers slide up the object set down in the bin (too weak to lift it)."""
SLIDE_HEIGHT = 0.04
"""m: the lift's position the fingers slide up to before they open. A grip that has turned with the robot keeps
contacts from where it was taken (PyBullet refreshes a gripping finger's contact points only when they slip):
their normals no longer face the object, and fingers that open against them stay stuck to it. Sliding the fingers
up the standing object moves every contact point along the surface, so they are made anew, facing the object."""
DOCK_STALL = 2.0
"""sim s: docking that makes no progress this long ends where it is."""
STAGE_NEAR = 0.25
"""m: carrying that gets no closer to the bin's stage point for ``DOCK_STALL`` sim s within this distance of it
docks from where it is (the navigator counts a goal within its tolerance as reached and barely moves there; the
docking steers onto the bin's centre line from there)."""
DROP_GRACE = 0.3
"""sim s: a held object counts as lost only when the gripper has not held it for this long in a row (a can jostled
in the fingers can lose one finger's contact points for a tick while still squeezed between them)."""
REST_HEIGHT = 0.15
"""m: an object whose centre is lower than this (world z) rests on the floor (a 0.2 m can standing: 0.1 m)."""


class PatrolCollectConfig(PatrolConfig):
    """Config of ``patrol_collect`` (everything ``patrol`` takes, plus the following).

    Attributes:
        collector: Name of the ``collector`` actuator (the scripted stow); empty with ``gripper``.
        gripper: Name of a ``gripper`` actuator whose fingers take the object (with ``lift`` and ``bin``).
        lift: Name of a ``joint_control`` actuator driving the lift joint.
        lift_joint: The lift's joint.
        carry_height: Lift position while carrying, m (the object's bottom must clear the lidar's scan plane).
        reach: Where an object sits between the fingers: metres ahead of the robot's base.
        grasp_time: Sim seconds allowed for closing the fingers and for moving the lift.
        deliver_timeout: Sim seconds allowed to carry one object into the bin.
        bin: The bin the gripper delivers into.
        truth_sensor: A ``body_pose`` sensor on the collectibles, read only to report localisation errors.
        approach_timeout: Sim seconds allowed to reach and collect one object before giving up on it.
        max_attempts: Approaches per object.
        discovery: Object discovery parameters.
    """

    collector: str = "collector"
    gripper: str = ""
    lift: str = ""
    lift_joint: str = "lift"
    carry_height: float = Field(0.15, gt=0)
    reach: float = Field(0.28, gt=0)
    grasp_time: float = Field(2.0, gt=0)
    deliver_timeout: float = Field(90.0, gt=0)
    bin: BinConfig | None = None
    truth_sensor: str = ""
    approach_timeout: float = Field(30.0, gt=0)
    max_attempts: int = Field(2, ge=1)
    discovery: DiscoveryConfig = Field(default_factory=DiscoveryConfig)


class PatrolCollect(Patrol):
    """Patrol waypoints; find unknown objects on the lidar, log and collect each, resume (lesson 08B)."""
    COMMANDS: ClassVar[tuple[str, ...]] = ("drive", "collector", "gripper", "lift")

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.TURNING

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg = self.config
        for key in ("collector", "gripper", "lift", "truth_sensor"):
            name = getattr(cfg, key)
            if name and name not in ctx.components:
                raise ConfigError(f"no component named {name!r}; components: {', '.join(ctx.components)}", key=key)
        if not cfg.scan:
            raise ConfigError("patrol_collect discovers objects with a lidar: name one in 'scan'", key="scan")
        self.bin = self._setup_gripper() if cfg.gripper else None
        if self.bin is None and not cfg.collector:
            raise ConfigError("name a 'collector', or a 'gripper' with a 'lift' and a 'bin'", key="collector")
        boxes = [(b.lo, b.hi) for b in self.map]
        if self.bin is not None:
            boxes.append(self.bin.cfg.area)  # objects already delivered belong to the bin
        self.discovery = Discovery(cfg.discovery, boxes)
        self.phase_started = 0.0
        self.lifting = False
        self.sliding = False  # releasing: the fingers slide up the object set down
        self.unheld_since: float | None = None  # since when the gripper has not reported holding the object
        self.delivered = 0
        self.dock_best = (math.inf, -1.0)  # (least depth still to go while docking, m; sim time it was reached)
        self.stage_best = (math.inf, -1.0)  # (least distance to the stage point while carrying, m; sim time)
        self.found: list[dict[str, Any]] = []
        self.target: Track | None = None
        self.approach_started = 0.0
        self.stage: tuple[float, float] | None = None
        self.collected_count = 0
        self.scan_stamp = -1.0
        self.collectables = self._collectables(ctx)

    def _setup_gripper(self) -> Bin:
        cfg = self.config
        if cfg.collector:
            raise ConfigError("give either 'collector' (the scripted stow) or 'gripper', not both", key="collector")
        if not cfg.lift or cfg.bin is None:
            raise ConfigError("a 'gripper' needs a 'lift' (joint_control actuator) and a 'bin'",
                              key="lift" if not cfg.lift else "bin")
        joints = getattr(getattr(self.ctx.components[cfg.lift], "config", None), "joints", ())
        if joints and cfg.lift_joint not in joints:
            raise ConfigError(f"actuator {cfg.lift!r} does not drive joint {cfg.lift_joint!r}; it drives "
                              f"{', '.join(joints)}", key="lift_joint")
        return Bin(cfg.bin, cfg.discovery.object_radius, cfg.reach)

    def _robot_name(self, ctx: SetupContext) -> str | None:
        device = ctx.components.get(self.config.gripper or self.config.collector)
        cfg = getattr(device, "config", None)
        return getattr(cfg, "robot", None) or getattr(cfg, "body", None)

    def _collectables(self, ctx: SetupContext) -> list[str]:
        """Ground truth for the goal: loose bodies the robot could take (not the robot, not on the map)."""
        collector = ctx.components.get(self.config.collector) if self.config.collector else None
        limit = getattr(getattr(collector, "config", None), "max_mass", math.inf)
        robot = self._robot_name(ctx)
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
        self.stage = None
        self.avoider.reset()
        self.fire("spotted")
        return self._tool(True)

    def _tool(self, ready: bool) -> dict[str, Any]:
        """Commands readying (or standing down) the mechanism: the stow armed, or the fingers open and lift down."""
        cfg = self.config
        if self.bin is None:
            return {cfg.collector: Collect(ready)}
        if not ready:
            return {}
        return {cfg.gripper: GripperCommand("open"), cfg.lift: JointCommand("position", {cfg.lift_joint: 0.0})}

    def do_approaching(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Drive at the target object: with the stow armed until the collector reports a new object, or until the
        object sits between the open fingers."""
        cfg, target = self.config, self.target
        assert target is not None
        if self.bin is None:
            state = readings[cfg.collector]
            if state.count > self.collected_count:
                self.collected_count = state.count
                taken = self.discovery.mark_collected(state.last_position or target.xy)
                self.ctx.trace("object_collected", id=taken.id if taken else None)
                return self._resume(t, "collected")
        if t - self.approach_started > cfg.approach_timeout:
            return self._give_up(t)
        pose = self.pose(readings)
        if self.bin is not None:
            dist = math.dist(pose[:2], target.xy)
            if dist < cfg.reach + 0.35:
                return self._creep(pose, target, t)
        ignore = (target.x, target.y, cfg.discovery.object_radius + 0.12)
        if self.bin is not None:  # the shared navigator (the rules, or A*) to a point short of the object
            return {cfg.drive: self.move_towards(readings, self._pregrasp(pose, target), t, ignore).twist}
        nav = self.avoider.step(pose, readings[cfg.scan], target.xy, t, ignore)
        return {cfg.drive: nav.twist}

    def _pregrasp(self, pose: tuple[float, float, float], target: Track) -> tuple[float, float]:
        """Where to drive before creeping in: ``reach`` + 0.3 m short of the object, on the robot's side of it
        (free space: a map that marked the object itself as an obstacle still has a way there). A later attempt
        stages a quarter turn round the object (left, then right), so a way that timed out is not driven again."""
        dx, dy = pose[0] - target.x, pose[1] - target.y
        d = math.hypot(dx, dy) or 1.0
        back = self.config.reach + 0.3
        if target.attempts < 2:
            return target.x + back * dx / d, target.y + back * dy / d
        if self.stage is None:  # fixed for the attempt: a side chosen from where the robot stood when it began
            turn = math.pi / 2 if target.attempts % 2 == 0 else -math.pi / 2
            c, s = math.cos(turn), math.sin(turn)
            self.stage = (target.x + back * (c * dx - s * dy) / d, target.y + back * (s * dx + c * dy) / d)
        return self.stage

    def _give_up(self, t: float) -> Mapping[str, Any]:
        target = self.target
        assert target is not None
        again = "deferred" if self.bin is not None else "found"  # the gripper tries again from the next waypoint
        target.status = again if target.attempts < self.config.max_attempts else "abandoned"
        return self._resume(t, "lost")

    def _undefer(self) -> None:
        for track in self.discovery.tracks:
            if track.status == "deferred":
                track.status = "found"

    def next_leg(self, t: float, reached: bool) -> Mapping[str, Any] | None:
        """As ``patrol``; objects given up on for now become pending again."""
        self._undefer()
        return super().next_leg(t, reached)

    def _creep(self, pose: tuple[float, float, float], target: Track, t: float) -> Mapping[str, Any]:
        """The last few decimetres: point at the object and roll forward until it is ``reach`` m ahead."""
        cfg = self.config
        dx, dy = target.x - pose[0], target.y - pose[1]
        dist = math.hypot(dx, dy)
        bearing = math.atan2(dy, dx) - pose[2]
        bearing = math.atan2(math.sin(bearing), math.cos(bearing))
        ahead, side = dist * math.cos(bearing), dist * math.sin(bearing)
        left = ahead - cfg.reach
        if left <= 0.005 and abs(side) <= 0.025:
            self.phase_started, self.unheld_since = t, None
            self.fire("within_reach")
            return {cfg.drive: STOP, cfg.gripper: GripperCommand("close")}
        omega = max(-1.0, min(1.0, 3.0 * bearing))
        if abs(bearing) > 0.15 or left <= 0.005:
            if left < -0.02 or (left <= 0.005 and abs(bearing) <= 0.15):
                return {cfg.drive: Twist(-0.05, 0.0)}  # too close to turn onto it: back off a little
            return {cfg.drive: Twist(0.0, omega)}
        return {cfg.drive: Twist(min(0.12, 0.02 + 0.6 * left), omega)}

    def do_grasping(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Fingers closing, then the lift rising; on to the bin once the object is held up."""
        cfg = self.config
        grip, lift = readings[cfg.gripper], readings[cfg.lift].positions[cfg.lift_joint]
        elapsed = t - self.phase_started
        if not self.lifting:
            if grip.holding and grip.settled:
                self.lifting, self.phase_started = True, t
                return {cfg.lift: JointCommand("position", {cfg.lift_joint: cfg.carry_height})}
            if elapsed > cfg.grasp_time:
                return {**self._give_up(t), cfg.gripper: GripperCommand("open")}
            return None
        if self._lost(grip.holding, t):
            return {**self._give_up(t), **self._tool(True)}
        if lift >= cfg.carry_height - 0.01 or elapsed > cfg.grasp_time:
            target = self.target
            assert target is not None
            self.lifting = False
            target.status = "collected"
            self.ctx.trace("object_lifted", id=target.id)
            self.phase_started = t
            self.avoider.reset()
            self.fire("lifted")
        return None

    def _lost(self, holding: bool, t: float) -> bool:
        """True once the gripper has not held the object for ``DROP_GRACE`` sim s in a row."""
        if holding:
            self.unheld_since = None
            return False
        if self.unheld_since is None:
            self.unheld_since = t
        return t - self.unheld_since >= DROP_GRACE

    def do_carrying(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Carry the held object to the stage point in front of the bin's mouth."""
        cfg, bin_ = self.config, self.bin
        assert bin_ is not None
        if self._lost(readings[cfg.gripper].holding, t) or t - self.phase_started > cfg.deliver_timeout:
            return self._dropped(t)
        pose = self.pose(readings)
        near = math.dist(pose[:2], bin_.stage)
        if self.stage_best[1] < self.phase_started or near < self.stage_best[0] - 0.005:
            self.stage_best = (near, t)
        if near <= 0.06 or (near <= STAGE_NEAR and t - self.stage_best[1] > DOCK_STALL):
            self.dock_best = (math.inf, -1.0)
            self.fire("at_bin")
            return {cfg.drive: STOP}
        return {cfg.drive: self.move_towards(readings, bin_.stage, t).twist}

    def do_docking(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Face the bin, drive straight in until the held object is over its slot (or, pushed against what is
        already there, has not got 5 mm closer for ``DOCK_STALL`` sim seconds: it is let go where it is)."""
        cfg, bin_ = self.config, self.bin
        assert bin_ is not None
        if self._lost(readings[cfg.gripper].holding, t) or t - self.phase_started > cfg.deliver_timeout:
            return self._dropped(t)
        twist, left = bin_.dock(self.pose(readings), self.delivered)
        if left < self.dock_best[0] - 0.005 or self.dock_best[1] < 0:
            self.dock_best = (left, t)
        if left <= 0.0 or t - self.dock_best[1] > DOCK_STALL:
            self.phase_started, self.sliding = t, False
            self.fire("over_slot")
            return {cfg.drive: STOP, cfg.lift: JointCommand("position", {cfg.lift_joint: RELEASE_HEIGHT})}
        return {cfg.drive: twist}

    def do_releasing(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Set the object down on the floor, slide the fingers (squeezing softly) up it, then open them."""
        cfg = self.config
        grip, lift = readings[cfg.gripper], readings[cfg.lift].positions[cfg.lift_joint]
        elapsed = t - self.phase_started
        if grip.action != "open":
            if not self.sliding:  # setting the object down
                if lift <= RELEASE_HEIGHT + 0.003 or elapsed > cfg.grasp_time:
                    self.phase_started, self.sliding = t, True
                    return {cfg.gripper: GripperCommand("close", force=SOFT_GRIP),
                            cfg.lift: JointCommand("position", {cfg.lift_joint: SLIDE_HEIGHT})}
                return None
            if lift >= SLIDE_HEIGHT - 0.003 or elapsed > cfg.grasp_time:  # the fingers have slid up
                self.phase_started = t
                return {cfg.gripper: GripperCommand("open")}
            return None
        opened = grip.width >= grip.target_width - 0.005  # wide open: backing out drags nothing along
        if opened or elapsed > cfg.grasp_time:
            self.delivered += 1
            self.collected_count = self.delivered
            self.ctx.trace("object_collected", id=self.target.id if self.target else None)
            self.fire("released")
        return None

    def do_leaving(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Back straight out of the bin to the stage point."""
        bin_ = self.bin
        assert bin_ is not None
        pose = self.pose(readings)
        depth, _ = bin_.along(pose[0], pose[1])
        if depth <= -bin_.cfg.stage_distance + 0.1:
            return self._resume(t, "delivered")
        return {self.config.drive: Twist(-bin_.cfg.dock_speed, 0.0)}

    def _dropped(self, t: float) -> Mapping[str, Any]:
        """The object left the fingers on the way: it is on the floor again, to be found and taken anew."""
        target = self.target
        if target is not None:
            target.status, target.found, target.sightings = "seen", False, 0
        self.ctx.trace("object_dropped", id=target.id if target else None)
        return {**self._resume(t, "dropped"), **self._tool(True)}

    def _resume(self, t: float, trigger: str) -> Mapping[str, Any]:
        """Back to the patrol (or to the end of it) after an approach."""
        self.target = None
        self.lifting = False
        self.avoider.reset()
        self.leg_started = t
        self.fire(trigger)
        out: dict[str, Any] = {**self._tool(False), self.config.drive: STOP}
        if self.leg >= self.legs_total:
            out.update(self.end_patrol(t) or {})
        return out

    def end_patrol(self, t: float) -> Mapping[str, Any] | None:
        """After the last waypoint, collect the objects already found, then finish."""
        x, y, _ = self.last.pose
        self._undefer()
        pending = self.discovery.nearest_pending(x, y, self.config.max_attempts)
        if pending is not None:
            return self._start_approach(pending, t)
        self.fire("finished")
        self.finish("failed" if self.missed else "succeeded", self._summary(t))
        return {self.config.drive: STOP, **self._tool(False)}

    def _summary(self, t: float) -> str:
        return (f"{len(self.reached)}/{self.legs_total} waypoints, {len(self.found)} objects found, "
                f"{self.collected_count} collected, t = {t:.2f} s")

    def check_goal(self, world: Any) -> GoalCheck:
        """Every waypoint visited, every collectable in the bin (the robot's, or the ``bin`` area), no collision
        (ground truth)."""
        problems = []
        if self.missed:
            problems.append(f"missed {len(self.missed)} of {self.legs_total} waypoint visits")
        left = [n for n in self.collectables if not (self._in_bin(world, n) if self.bin else self._stowed(world, n))]
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

    def _in_bin(self, world: Any, name: str) -> bool:
        """True if a body rests in the ``bin`` area (world state): its centre inside the area, below
        ``REST_HEIGHT``, and nothing of the robot touching it."""
        assert self.bin is not None
        if not world.has_body(name):
            return False
        x, y, z = world.pose(name)[0]
        robot = self._robot_name(self.ctx)
        held = robot is not None and world.has_body(robot) and bool(world.contacts(world.body(name), world.body(robot)))
        return self.bin.contains(x, y) and z < REST_HEIGHT and not held

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
            "mechanism": "gripper" if self.bin is not None else "stow",
            "found": self.found,
            "localisation_error_median": round(statistics.median(errors), 4) if errors else None,
        })
        return out


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("patrol_collect", PatrolCollect, PatrolCollectConfig)
