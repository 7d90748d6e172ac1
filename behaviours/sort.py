"""``sort`` behaviour (lesson 08, project A): look with a camera, pick each coloured object, drop it in its bin.

The loop: **LOOK** (one camera frame through the ``colour_detector``) -> choose the detected object of a colour that
has a bin, nearest to the gripper -> **PICK_PLACE** (the ``pick_place`` behaviour, reused as a sub-machine, one
attempt) -> LOOK again (things move: a dropped or nudged object is found where it is now) ... until nothing
sortable is seen (**DONE**, succeeded) or the attempts run out (**FAILED**). Objects of a colour without a bin are
left where they are and reported. Detections inside a bin (plus ``bin_margin``) are ignored: what is sorted stays
sorted.

Perception uses the image and depth only. Ground truth (an optional ``body_pose`` sensor, ``truth_sensor``) is
read for the report alone: which body a detection was, and how far the detected position was from it.

Identity across looks is by colour and position: an object whose pick failed is the same object as the next
detection of its colour nearest to where it was last seen. An object that failed ``max_attempts`` times is given
up and detections near its last position are ignored from then on.

The goal (:meth:`Sort.check_goal`, evaluated on the world after the last tick): every loose object (a movable body
with no joints) whose true colour (its ``rgba``, classified with the detector's colour classes) has a bin lies in
that bin, and no loose object has a colour that no class matches. The per-colour counts of the result are counted
in the world the same way. An object that misses the goal is named with the reason: never seen by the detector,
its colour matches no class, or the last failure of its picks (unreachable, grasp failed, dropped...).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from pydantic import Field
from robokit_behaviours.pick_place import PickPlace, PickPlaceTask

from robokit import hookimpl
from robokit.components import GoalCheck, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError, did_you_mean
from robokit.fsm import MachineBehaviour
from robokit.msgs.arm import ArmState, GripperCommand, MoveTo, down_quaternion, yaw_of
from robokit.msgs.vision import Detection, Detections

Vec3 = tuple[float, float, float]


class Phase(enum.Enum):
    """States of the sorting machine."""

    LOOK = "look"
    PICK_PLACE = "pick_place"
    CLEAR_VIEW = "clear_view"
    DONE = "done"
    FAILED = "failed"


TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "found", "source": "LOOK", "dest": "PICK_PLACE"},
    {"trigger": "placed", "source": "PICK_PLACE", "dest": "LOOK"},
    {"trigger": "missed", "source": "PICK_PLACE", "dest": "CLEAR_VIEW"},
    {"trigger": "view_clear", "source": "CLEAR_VIEW", "dest": "LOOK"},
    {"trigger": "clear", "source": "LOOK", "dest": "DONE"},
    {"trigger": "exhausted", "source": "LOOK", "dest": "FAILED"},
    {"trigger": "stuck", "source": ["LOOK", "PICK_PLACE", "CLEAR_VIEW"], "dest": "FAILED"},
]

TIMEOUTS = {"LOOK": 1.0, "PICK_PLACE": 20.0, "CLEAR_VIEW": 4.0}
"""Sim seconds per state (a pick-and-place has its own per-phase timeouts; this is a backstop)."""


class BinConfig(Schema):
    """A bin: ``body`` names a body in the scene; objects are placed on a grid of ``slots`` around its centre."""

    body: str
    floor: float = Field(default=0.008, ge=0, description="bin floor height above the bin's base, metres")
    slot_spacing: float = Field(default=0.07, ge=0, description="distance between place slots, metres")


class SortConfig(Schema):
    """``[behaviour]`` with ``type = "sort"``.

    ``bins`` maps a colour class of the detector to a bin. Lengths in metres, times in sim seconds.
    """

    detector: str = Field(default="detector", description="a colour_detector sensor")
    arm: str = Field(default="arm", description="an ik_arm actuator")
    gripper: str = Field(default="gripper", description="a gripper actuator")
    bins: dict[str, BinConfig] = Field(default_factory=dict)
    truth_sensor: str | None = Field(default=None, description="a body_pose sensor, for the report only")
    object_size: float = Field(default=0.05, gt=0, description="edge length of the objects, metres")
    max_attempts: int = Field(default=3, ge=1, le=20, description="pick attempts per object")
    max_picks: int = Field(default=30, ge=1, description="pick attempts in total")
    bin_margin: float = Field(default=0.02, ge=0, description="detections this close to a bin are in it")
    same_object_radius: float = Field(default=0.15, gt=0, description="a retry's detection is within this")
    look_position: Vec3 = Field(default=(0.28, 0.0, 0.34),
                                description="gripper position out of the camera's view: first look, after a miss")
    look_tolerance: float = Field(default=0.05, gt=0, description="at the start, closer than this is there")
    pick_place: dict[str, Any] = Field(default_factory=dict, description="options of the pick_place sub-machine")
    planner: Literal["straight", "rrt"] = Field("straight", description="the arm's free moves: 'straight' lines, "
                                                "or 'rrt': around obstacles where the straight way is blocked "
                                                "(pick_place's planner; docs/motion_planning.md)")


@dataclass
class Bin:
    """A bin resolved at setup: its place slots (object centres, metres, world) and its footprint."""

    colour: str
    body: str
    slots: list[Vec3]
    low: tuple[float, float]
    high: tuple[float, float]
    used: int = 0
    top: float = math.inf

    def next_slot(self) -> Vec3:
        """The next place position (cycles through the slots), taken."""
        slot = self.free_slot()
        self.used += 1
        return slot

    def free_slot(self) -> Vec3:
        """The next place position, not yet taken (a pick that does not place leaves it free)."""
        return self.slots[self.used % len(self.slots)]

    def holds(self, position: Vec3) -> bool:
        """True if an object centre (metres, world) is over the bin's footprint and below its rim."""
        x, y, z = position
        return self.low[0] <= x <= self.high[0] and self.low[1] <= y <= self.high[1] and z < self.top

    def contains(self, x: float, y: float, margin: float) -> bool:
        """True if ``(x, y)`` lies over the bin's footprint grown by ``margin`` metres."""
        return self.low[0] - margin <= x <= self.high[0] + margin and self.low[1] - margin <= y <= self.high[1] + margin


@dataclass
class SortedObject:
    """What the sort knows of one object (for decisions: colour and detected positions; truth: report only)."""

    colour: str
    detected: Vec3
    yaw: float
    bin: str | None
    attempts: int = 0
    outcome: str = "pending"
    reason: str = ""
    body: str | None = None
    detection_error: float | None = None
    failures: list[str] = field(default_factory=list)
    handling_time: float = 0.0
    picked: str | None = None
    """Report only: the loose object (ground truth) the first pick of this object was about."""

    def report(self) -> dict[str, Any]:
        """JSON-ready summary."""
        err = None if self.detection_error is None else round(self.detection_error, 5)
        return {"colour": self.colour, "detected_position": [round(v, 4) for v in self.detected],
                "detection_error": err, "body": self.body, "bin": self.bin, "attempts": self.attempts,
                "outcome": self.outcome, "reason": self.reason, "pick_place_time": round(self.handling_time, 4)}


class Sort(MachineBehaviour):
    """Colour sorting: look, pick the nearest sortable object with pick_place, drop it in its bin, look again."""
    COMMANDS: ClassVar[tuple[str, ...]] = ("arm", "gripper")

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.CLEAR_VIEW
    TIMEOUTS = TIMEOUTS

    # ------------------------------------------------------------------ setup
    def setup(self, ctx: SetupContext) -> None:
        """Check the detector, the bins (colour classes and bodies) and build the pick_place sub-machine."""
        super().setup(ctx)
        cfg: SortConfig = self.config
        self.colours = self._detector_colours(ctx)
        if not cfg.bins:
            raise ConfigError("no bins: give at least one, e.g. bins.red = { body = \"red_bin\" }", key="bins")
        self.bins = {colour: self._bin(ctx, colour, b) for colour, b in cfg.bins.items()}
        if cfg.truth_sensor is not None and cfg.truth_sensor not in ctx.components:
            raise ConfigError(str(LookupNameError("sensor", cfg.truth_sensor, ctx.components)), key="truth_sensor")
        try:
            self.pp = PickPlace.sub(name="pick_place", parent_ctx=ctx, arm=cfg.arm, gripper=cfg.gripper,
                                    max_attempts=1, api=1, key="pick_place",
                                    **{"planner": cfg.planner, **cfg.pick_place})
        except ConfigError as exc:
            raise ConfigError(exc.message, key=exc.key) from None
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"bad pick_place option: {exc}".splitlines()[0], key="pick_place") from None
        self.goal_objects = self._loose_objects(ctx)
        self._positions: list[tuple[Vec3, str]] = []
        self._positions_at = -1
        self.seen: set[str] = set()
        self.objects: list[SortedObject] = []
        self.left: list[dict[str, Any]] = []
        self.current: SortedObject | None = None
        self.looks = 0
        self.picks = 0
        self._view_command: int | None = None
        self.started_at: float | None = None
        self.finished_at: float | None = None
        self._renders_before: int | None = None
        """The camera's renders before this sort's first step (a sequence's later step counts its own only)."""

    def _detector_colours(self, ctx: SetupContext) -> tuple[str, ...]:
        cfg: SortConfig = self.config
        det = ctx.components.get(cfg.detector)
        if det is None or getattr(det, "reading_type", None) is not Detections:
            found = [n for n, c in ctx.components.items() if getattr(c, "reading_type", None) is Detections]
            raise ConfigError(str(LookupNameError("colour_detector sensor", cfg.detector, found)), key="detector")
        colours = getattr(det, "colours", None)
        return tuple(colours) if colours is not None else ()

    def _loose_objects(self, ctx: SetupContext) -> dict[str, str | None]:
        """Ground truth for the goal: every loose body (movable, no joints, not a bin) and its colour class
        from its true ``rgba`` (None when no class of the detector matches it)."""
        bins = {b.body for b in self.bins.values()}
        world, out = ctx.world, {}
        for name in world.body_names:
            bid = world.body(name)
            if name in bins or world.joints(bid) or world.mass(bid) <= 0:
                continue
            rgba = world.visual_rgba(bid)
            out[name] = self._colour_class(rgba[:3]) if rgba is not None else None
        return out

    def _colour_class(self, rgb: Any) -> str | None:
        """The first colour class of the detector whose HSV ranges contain a true colour (0-1 floats)."""
        classes = getattr(self.ctx.components.get(self.config.detector), "colours", None)
        if not isinstance(classes, Mapping):
            return None
        for name, cls in classes.items():
            contains = getattr(cls, "contains_rgb", None)
            if contains is not None and contains(rgb):
                return str(name)
        return None

    def _bin(self, ctx: SetupContext, colour: str, cfg: BinConfig) -> Bin:
        if colour not in self.colours:
            known = ", ".join(self.colours)
            raise ConfigError(f"bin for undefined colour {colour!r}{did_you_mean(colour, self.colours)}; "
                              f"colour classes of detector {self.config.detector!r}: {known}", key=f"bins.{colour}")
        if not ctx.world.has_body(cfg.body):
            raise ConfigError(str(LookupNameError("body", cfg.body, ctx.world.body_names)), key=f"bins.{colour}.body")
        (bx, by, bz), _ = ctx.world.pose(cfg.body)
        lo, hi = ctx.world.body_aabb(cfg.body)
        z = bz + cfg.floor + self.config.object_size / 2.0
        d = cfg.slot_spacing / 2.0
        offsets = [(-d, -d), (d, d), (-d, d), (d, -d), (0.0, 0.0)] if d > 0 else [(0.0, 0.0)]
        slots = [(bx + ox, by + oy, z) for ox, oy in offsets]
        return Bin(colour, cfg.body, slots, (lo[0], lo[1]), (hi[0], hi[1]), top=hi[2])

    # ------------------------------------------------------------------ LOOK
    def do_look(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Read one detection frame (fresh: taken after entering LOOK) and decide what to do next."""
        self._first_step(t)
        seen: Detections = readings[self.config.detector]
        if seen.time < self.entered_at - 1e-9:
            return None  # the camera has not been due since LOOK began: wait for a fresh frame
        self.looks += 1
        for d in seen:
            self._attribute(d.position)
        sortable, unknown = self._classify(seen)
        self.left = [{"colour": d.colour, "detected_position": [round(v, 4) for v in d.position],
                      "outcome": "left", "reason": f"no bin for {d.colour}"} for d in unknown]
        if not sortable:
            self._end("clear", "succeeded", self._summary())
            return None
        if self.picks >= self.config.max_picks:
            self._end("exhausted", "failed", f"{self.picks} pick attempts used up; "
                      f"{len(sortable)} sortable object(s) remain")
            return None
        target = min(sortable, key=lambda d: self._distance_to_gripper(readings, d))
        self._start_pick(readings, target, t)
        return None

    def _classify(self, seen: Detections) -> tuple[list[Detection], list[Detection]]:
        """Split detections into sortable ones (a bin exists, not in a bin, not given up) and unknown colours."""
        cfg: SortConfig = self.config
        sortable, unknown = [], []
        for d in seen:
            x, y, _ = d.position
            if any(b.contains(x, y, cfg.bin_margin) for b in self.bins.values()):
                continue
            if d.colour not in self.bins:
                unknown.append(d)
            elif not self._given_up_near(d):
                sortable.append(d)
        return sortable, unknown

    def _given_up_near(self, d: Detection) -> bool:
        r = self.config.same_object_radius / 3.0
        return any(o.outcome == "failed" and o.colour == d.colour and math.dist(o.detected, d.position) < r
                   for o in self.objects)

    def _distance_to_gripper(self, readings: Mapping[str, Any], d: Detection) -> float:
        arm = readings.get(self.config.arm)
        here = arm.position if isinstance(arm, ArmState) else (0.0, 0.0, 0.0)
        return math.dist(here[:2], d.position[:2])

    def _start_pick(self, readings: Mapping[str, Any], d: Detection, t: float) -> None:
        obj = self._object_for(d)
        obj.detected, obj.yaw = d.position, d.yaw
        self._record_truth(readings, obj)
        truth = self._attribute(d.position)
        obj.picked = obj.picked or truth
        obj.body = obj.body or truth
        obj.attempts += 1
        self.picks += 1
        self.current = obj
        place = self.bins[d.colour].free_slot()  # taken when the pick places, skipped if it fails on the way there
        task = PickPlaceTask(pick_position=d.position, pick_yaw=d.yaw, place_position=place,
                             object_name=obj.body, object_size=self.config.object_size)
        self.fire("found")
        self.pp.start(task, t)

    def _object_for(self, d: Detection) -> SortedObject:
        """The object a detection is: a pending retry of its colour nearby, else a new one."""
        retries = [o for o in self.objects if o.outcome == "retry" and o.colour == d.colour
                   and math.dist(o.detected[:2], d.position[:2]) < self.config.same_object_radius]
        if retries:
            return min(retries, key=lambda o: math.dist(o.detected, d.position))
        obj = SortedObject(d.colour, d.position, d.yaw, self.bins[d.colour].body)
        self.objects.append(obj)
        return obj

    def _attribute(self, position: Vec3) -> str | None:
        """Report only: the loose object (ground truth) a detection or pick was about, marked as seen."""
        world = self.ctx.world
        if self._positions_at != world.tick:  # the loose objects' positions, once a tick (a look attributes several)
            self._positions = [(world.pose(n)[0], n) for n in self.goal_objects if world.has_body(n)]
            self._positions_at = world.tick
        near = [(math.dist(pos[:2], position[:2]), n) for pos, n in self._positions]
        dist, name = min(near, default=(math.inf, None))
        if name is None or dist > self.config.same_object_radius / 2.0:
            return None
        self.seen.add(name)
        return name

    def _record_truth(self, readings: Mapping[str, Any], obj: SortedObject) -> None:
        """Report only: the body nearest to the detected position and the detection error."""
        if self.config.truth_sensor is None:
            return
        poses = readings[self.config.truth_sensor]
        if not poses:
            return
        name, state = min(poses.items(), key=lambda kv: math.dist(kv[1].position, obj.detected))
        obj.body, obj.detection_error = name, math.dist(state.position, obj.detected)

    # ------------------------------------------------------------------ PICK_PLACE
    def do_pick_place(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Step the pick_place sub-machine; when it ends, book the outcome and look again."""
        commands = self.pp.step(readings, t)
        if self.pp.outcome is None:
            return commands
        obj = self.current
        assert obj is not None
        obj.handling_time += float(self.pp.result().get("sim_time") or 0.0)
        if self.pp.outcome.status == "succeeded":
            obj.outcome, obj.reason = "sorted", ""
            self.bins[obj.colour].next_slot()
            self.fire("placed")
        else:
            if "TRANSPORT" in self.pp.phase_times:  # it failed on the way to the slot, which may be out of reach:
                self.bins[obj.colour].next_slot()  # the next attempt tries the next one
            reason = self.pp.outcome.reason
            obj.failures.append(reason)
            given_up = obj.attempts >= self.config.max_attempts
            obj.outcome, obj.reason = ("failed" if given_up else "retry"), reason
            self.current = None
            return self._clear_view(readings)
        self.current = None
        return commands

    def _clear_view(self, readings: Mapping[str, Any]) -> Mapping[str, Any]:
        """After a miss the arm may be over the table: open the gripper and move out of the camera's view."""
        cfg: SortConfig = self.config
        arm = readings[cfg.arm]
        self._view_command = arm.command_id if isinstance(arm, ArmState) else 0
        self.fire("missed")
        return {cfg.arm: self._look_move(), cfg.gripper: GripperCommand("open")}

    def _look_move(self) -> Any:
        """The move to ``look_position``: straight, or with ``planner = "rrt"`` around what blocks the straight
        way (straight when no way is found: the planner's counts in the result say so)."""
        cfg: SortConfig = self.config
        moves = self.pp.moves
        planned = moves.move(cfg.look_position, down_quaternion(0.0), None) if moves is not None else None
        return planned or MoveTo(cfg.look_position)

    def do_clear_view(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Wait until the arm has reached the look position (its new command is done), then look.

        At the start the gripper goes to ``look_position`` only if it is not already within ``look_tolerance``
        of it (a ready pose out of the camera's view costs nothing).
        """
        cfg: SortConfig = self.config
        self._first_step(t)
        arm = readings[cfg.arm]
        if not isinstance(arm, ArmState):
            return None
        if self._view_command is None:
            if math.dist(arm.position, cfg.look_position) <= cfg.look_tolerance:
                return self._view_clear(readings, t)
            self._view_command = arm.command_id
            return {cfg.arm: self._look_move(), cfg.gripper: GripperCommand("open")}
        if arm.command_id <= self._view_command:
            return None
        if arm.failed:
            self._end("stuck", "failed", f"could not move out of the camera's view: {arm.reason}")
        elif arm.reached:
            return self._view_clear(readings, t)
        return None

    def _view_clear(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        self._view_command = None
        self.fire("view_clear")
        return self.do_look(readings, t)

    def on_timeout(self, state: str) -> None:
        """LOOK without a fresh frame, or a stuck sub-machine: fail with the reason."""
        self._end("stuck", "failed", f"timed out in state {state} after {self.timeouts[state]:g} s (sim time)")

    # ------------------------------------------------------------------ end and result
    def _end(self, trigger: str, status: str, reason: str) -> None:
        self.fire(trigger)
        self.finished_at = self.t
        for obj in self.objects:
            if obj.outcome in ("pending", "retry"):
                obj.outcome = "failed"
        if status == "succeeded" and any(o.outcome == "failed" for o in self.objects):
            status = "failed"
        self.finish(status, reason)

    def _summary(self) -> str:
        done = sum(o.outcome == "sorted" for o in self.objects)
        there = len(self._in_bins())  # what the goal check will count: say so when it is fewer than were placed
        text = (f"sorted {done} object(s) in {self.picks} pick(s)" if there >= done else
                f"placed {done} object(s) in their bins in {self.picks} pick(s), {there} still there")
        no_bin = sorted({str(o["colour"]) for o in self.left})
        return text + (f"; left {len(self.left)} whose colour has no bin ({', '.join(no_bin)})" if self.left else "")

    def halt(self, t: float) -> Mapping[str, Any] | None:
        """Stopped before it ended (a composite's timeout, a monitor): as pick_place's halt, the arm holds where it
        is and the gripper keeps what it holds."""
        return self.pp.halt(t)

    def result(self) -> dict[str, Any]:
        """Counts per colour, failures (failed pick attempts), sim time, and one record per object."""
        counts = {f"{c}_sorted": 0 for c in (*self.colours, *self.bins)}
        for colour in self._in_bins().values():
            counts[f"{colour}_sorted"] += 1
        start = self.started_at or 0.0
        end = self.finished_at if self.finished_at is not None else self.t
        frames = self._frames()
        return {
            **counts,
            "failures": sum(len(o.failures) for o in self.objects),
            "misses": {"count": sum(len(o.failures) for o in self.objects),  # the sort's own, retried or not
                       "reasons": [f"{o.body or o.colour}: {why}" for o in self.objects for why in o.failures]},
            "total_time": round(end - start, 4),
            "looks": self.looks,
            "picks": self.picks,
            **({"camera_frames": frames} if frames is not None else {}),
            "objects": [o.report() for o in self.objects] + self.left,
            **({"planner": self.pp.moves.stats.as_dict()} if self.pp.moves is not None else {}),
        }

    # ------------------------------------------------------------------ preflight (before the first tick)
    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Every loose object's colour is a class of the detector, lies in the camera's view and within the arm's
        reach; every bin's place slots are within reach."""
        cfg: SortConfig = self.config
        problems = []
        arm = ctx.components.get(cfg.arm)
        moves_check = getattr(arm, "check_moves", None)
        reach = None if moves_check is not None else getattr(arm, "check_reach", None)
        pp: Any = self.pp.config
        if moves_check is not None:  # the run's own moves, planned by the arm (see sort_reach)
            problems += self._reach_problems(ctx, moves_check)
        for bin_colour, b in self.bins.items() if reach is not None else ():
            for x, y, z in b.slots:
                why = reach((x, y, z + pp.grasp_offset + pp.place_clearance))  # type: ignore[misc]
                if why:
                    problems.append(ctx.problem(f"bin {b.body!r} is out of the reach of arm {cfg.arm!r}: {why}",
                                                f"bins.{bin_colour}"))
                    break
        camera = self._camera(ctx)
        for name, colour in self.goal_objects.items():
            key = ctx.body_key(name)
            pos = ctx.world.pose(name)[0]
            where = f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f})"
            if colour is None:
                problems.append(ConfigError(self._unknown_colour(ctx, name), key=f"{key}.rgba"))
                continue
            if colour not in self.bins:
                continue
            if camera is not None and not camera.in_view((pos[0], pos[1], pos[2] + cfg.object_size / 2.0)):
                problems.append(ConfigError(f"{name} at {where} is outside the view of camera "
                                            f"{getattr(camera, 'name', '?')!r}: the sort would never see it", key=key))
            why = reach((pos[0], pos[1], pos[2] + pp.grasp_offset)) if reach is not None else ""
            if why:
                problems.append(ConfigError(f"{name} at {where} is out of the reach of arm {cfg.arm!r}: {why}",
                                            key=key))
        return problems

    def _reach_problems(self, ctx: SetupContext, check_moves: Any) -> list[ConfigError]:
        """One problem per object whose pick-and-place the arm would reject, naming the object or its bin."""
        from robokit_behaviours.sort_reach import STEPS, sort_picks, unreachable

        objects = [(name, colour, ctx.world.pose(name)[0], yaw_of(ctx.world.pose(name)[1]))
                   for name, colour in self.goal_objects.items() if colour in self.bins]
        slots = {colour: b.slots for colour, b in self.bins.items()}
        picks = sort_picks(self.config.look_position, objects, slots, self.pp.config, self.config.max_attempts)
        problems = []
        for move, why in unreachable(self.config.look_position, picks, check_moves):
            if move.step < 0:
                problems.append(ctx.problem(f"look_position is out of the reach of arm {self.config.arm!r}: {why}",
                                            "look_position"))
            elif move.step >= 2:
                b = self.bins[move.colour]
                problems.append(ctx.problem(f"bin {b.body!r} is out of the reach of arm {self.config.arm!r} "
                                            f"(placing {move.object}, {STEPS[move.step]}): {why}",
                                            f"bins.{move.colour}"))
            else:
                problems.append(ConfigError(f"{move.object} is out of the reach of arm {self.config.arm!r} "
                                            f"({STEPS[move.step]}): {why}", key=ctx.body_key(move.object)))
        return problems

    def _camera(self, ctx: SetupContext) -> Any:
        """The detector's camera component, if it can tell what it sees (``in_view``)."""
        det = ctx.components.get(self.config.detector)
        camera = ctx.components.get(getattr(getattr(det, "config", None), "camera", ""))
        return camera if hasattr(camera, "in_view") else None

    def _unknown_colour(self, ctx: SetupContext, name: str) -> str:
        rgba = [round(v, 3) for v in ctx.world.visual_rgba(ctx.world.body(name)) or ()]
        classes = getattr(ctx.components.get(self.config.detector), "colours", {}) or {}
        return (f"colour {rgba} of {name!r} matches no colour class of detector {self.config.detector!r} "
                f"({', '.join(classes) or 'none'}): the sort could never see it; change the colour or add a class")

    # ------------------------------------------------------------------ goal (ground truth, after the run)
    def _in_bins(self) -> dict[str, str]:
        """Loose objects lying in the bin of their true colour now (world poses), name -> colour."""
        world = self.ctx.world
        return {name: colour for name, colour in self.goal_objects.items()
                if colour in self.bins and world.has_body(name) and self.bins[colour].holds(world.pose(name)[0])}

    def check_goal(self, world: Any) -> GoalCheck:
        """Every loose object of a colour with a bin is in that bin, and every loose object's colour is known."""
        inside = self._in_bins()
        missed: dict[str, list[str]] = {}
        for name, colour in self.goal_objects.items():
            if name in inside or (colour is not None and colour not in self.bins):
                continue
            missed.setdefault(self._why(world, name, colour), []).append(name)
        total = sum(c is None or c in self.bins for c in self.goal_objects.values())
        details = {"in_bin": sorted(inside), "missed": {n: why for why, names in missed.items() for n in names}}
        if not missed:
            return GoalCheck(True, f"all {total} sortable object(s) in their bins", details)
        parts = [f"{', '.join(names)} ({why})" for why, names in missed.items()]
        count = sum(len(n) for n in missed.values())
        return GoalCheck(False, f"{count} of {total} object(s) not in their bin: " + "; ".join(parts), details)

    def _why(self, world: Any, name: str, colour: str | None) -> str:
        """Why a loose object is not in its bin (from what the sort did with it)."""
        if colour is None:
            return f"its colour matches no colour class of detector {self.config.detector!r}, never detected"
        if not world.has_body(name):
            return "removed from the world"
        picked = [o for o in self.objects if name in (o.picked, o.body)]
        if picked:
            obj = picked[-1]
            if obj.outcome == "sorted":
                return f"placed in {self.bins[colour].body} but not there at the end"
            return obj.reason or f"pick {obj.outcome}"
        if name in self.seen:
            return "seen by the detector but never picked"
        return f"never seen by detector {self.config.detector!r}"

    def _first_step(self, t: float) -> None:
        if self.started_at is None:
            self.started_at = t
        if self._renders_before is None:
            self._renders_before = self._renders() or 0

    def _renders(self) -> int | None:
        """The camera's renders in the run so far (None when the detector's camera is not known)."""
        camera = getattr(self.ctx.components.get(self.config.detector), "cfg", None)
        computed = getattr(self.ctx.readings, "computed", None)
        name = getattr(camera, "camera", None)
        return int(computed(name)) if computed is not None and name in self.ctx.components else None

    def _frames(self) -> int | None:
        """Camera frames rendered while this sort ran (from its first step on)."""
        renders = self._renders()
        if renders is None:
            return None
        return renders - (self._renders_before if self._renders_before is not None else renders)


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("sort", Sort, SortConfig)
