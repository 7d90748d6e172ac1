"""``pick_place`` behaviour: pick one object with an ``ik_arm`` and a friction ``gripper``, place it at a spot.

States advance on conditions (pose reached, gripper settled, hold verified), never after fixed waits; each state
has a sim-time timeout. A failed grasp, a drop or a timeout while handling the object starts a new attempt (the
object is located again) until ``max_attempts`` is used up; then the behaviour fails with the reason.

Two ways to use it:

- as the top-level behaviour ``type = "pick_place"``: the object's pose comes from a ``body_pose`` sensor by name;
  ``objects = [...]`` (names) or ``pick_positions = [...]`` (known positions, as lesson 06 teaches) move several
  objects one after another to the same spot, each placed on top of what is already there (stacking);
- as a sub-machine of a larger behaviour (sorting): ``PickPlace.sub(name=..., parent_ctx=ctx, arm=..., gripper=...)``,
  then ``start(PickPlaceTask(...), t)`` and ``step(readings, t)`` each tick until ``outcome`` is set.

Heights: positions are object *centres*, metres, world frame. The tool-centre point (the arm's end-effector link)
goes to the object centre plus ``grasp_offset`` to grasp and is released ``place_clearance`` above the place
position.

The goal (top-level use, :meth:`PickPlace.check_goal`, evaluated on the world after the last tick): the object rests
(slower than ``REST_SPEED``, not touching the robot) with its centre within ``place_tolerance`` of ``place_position``.
A top-level ``pick_place`` without ``object``, ``pose_sensor`` or ``place_position`` is a config error.
With several objects the goal is that every one rests on the place spot (horizontally within ``place_tolerance``;
stacked ones at any height).

Stacking: the place height is measured when a job starts, from the ``body_pose`` readings: a body already on the
spot (within 0.75 object sizes horizontally) raises the place position to rest on its top.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from pydantic import Field, field_validator
from robokit_behaviours.pick_place_jobs import (
    REST_SPEED,
    Job,
    all_rest_on_spot,
    identify,
    jobs_from,
    object_rests_at,
    stacked_place,
)

from robokit import hookimpl
from robokit.components import GoalCheck, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.fsm import MachineBehaviour
from robokit.msgs.arm import (
    ArmState,
    GripperCommand,
    GripperState,
    HoldArm,
    MoveTo,
    Vec3,
    cube_grasp_yaw,
    down_quaternion,
    yaw_of,
)
from robokit.planning.arm import ArmPlanning


class Phase(enum.Enum):
    """States of the pick-and-place machine, in the order a clean run visits them."""

    WAIT = "wait"
    APPROACH = "approach"
    DESCEND = "descend"
    GRASP = "grasp"
    LIFT = "lift"
    TRANSPORT = "transport"
    LOWER = "lower"
    RELEASE = "release"
    RETREAT = "retreat"
    DONE = "done"
    FAILED = "failed"


CARRYING = ("GRASP", "LIFT", "TRANSPORT", "LOWER", "RELEASE")
"""States in which the object may be in the fingers."""
HANDLING = ["GRASP", "LIFT", "TRANSPORT", "LOWER", "DESCEND", "APPROACH", "RELEASE", "RETREAT"]

TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "begin", "source": "WAIT", "dest": "APPROACH"},
    {"trigger": "above_object", "source": "APPROACH", "dest": "DESCEND"},
    {"trigger": "at_object", "source": "DESCEND", "dest": "GRASP"},
    {"trigger": "grasped", "source": "GRASP", "dest": "LIFT"},
    {"trigger": "hold_verified", "source": "LIFT", "dest": "TRANSPORT"},
    {"trigger": "above_place", "source": "TRANSPORT", "dest": "LOWER"},
    {"trigger": "at_place", "source": "LOWER", "dest": "RELEASE"},
    {"trigger": "released", "source": "RELEASE", "dest": "RETREAT"},
    {"trigger": "clear", "source": "RETREAT", "dest": "DONE"},
    {"trigger": "retry", "source": HANDLING, "dest": "APPROACH"},
    {"trigger": "give_up", "source": ["WAIT", *HANDLING], "dest": "FAILED"},
    {"trigger": "reset", "source": ["DONE", "FAILED"], "dest": "WAIT"},
]

TIMEOUTS = {"APPROACH": 3.0, "DESCEND": 2.0, "GRASP": 1.0, "LIFT": 2.0, "TRANSPORT": 3.0, "LOWER": 2.0,
            "RELEASE": 1.0, "RETREAT": 2.0}
"""Sim seconds allowed per state."""
PLANNED_TIMEOUT = 8.0
"""Sim seconds allowed for APPROACH and TRANSPORT with ``planner = "rrt"`` (unless ``timeouts`` says otherwise)."""


@dataclass(frozen=True)
class PickPlaceTask:
    """One pick-and-place job. Positions are object centres, metres, world frame; yaw in radians."""

    pick_position: tuple[float, float, float]
    pick_yaw: float
    place_position: tuple[float, float, float]
    object_name: str | None = None
    object_size: float = 0.05


class PickPlaceConfig(Schema):
    """``[behaviour]`` with ``type = "pick_place"`` (the same options apply to :meth:`PickPlace.sub`)."""

    arm: str = Field("arm", description="an ik_arm actuator")
    gripper: str = Field("gripper", description="a gripper actuator")
    pose_sensor: str | None = Field(None, description="a body_pose sensor that sees the object")
    object: str | None = Field(None, description="body to pick (top-level use)")
    objects: list[str] = Field(default_factory=list, description="bodies to pick one after another (top-level use)")
    pick_positions: list[Vec3] = Field(default_factory=list,
                                       description="known object centres to pick from, in order, m (top-level use)")
    place_position: Vec3 | None = Field(None, description="object centre at the place spot, m (top-level use)")
    object_size: float = Field(0.05, gt=0, description="edge length, m (top-level use)")
    max_attempts: int = Field(3, ge=1, le=20)
    approach_height: float = Field(0.07, gt=0, description="TCP above the grasp point before descending, m")
    lift_height: float = Field(0.08, gt=0, description="transport altitude above max(pick, place) z, m")
    retreat_height: float = Field(0.05, gt=0, description="rise after release, m")
    grasp_offset: float = Field(0.0, description="TCP z relative to the object centre when grasping, m")
    place_clearance: float = Field(0.004, ge=0, description="release height above the place position, m")
    speed: float = Field(1.2, gt=0, description="peak speed of free moves, m/s")
    slow_speed: float = Field(0.6, gt=0, description="peak speed near the object, m/s")
    grasp_force: float | None = Field(None, gt=0, description="N; default the gripper's force")
    place_tolerance: float = Field(0.02, gt=0, description="max placement error for success, m")
    hold_check_hz: float | None = Field(60.0, gt=0, description="how often (sim Hz) a carried object is checked "
                                        "for a drop while the arm moves; None = every tick. At the end of every "
                                        "move it is checked on each tick")
    timeouts: dict[str, float] = Field(default_factory=dict, description="state name -> sim seconds")
    planner: Literal["straight", "rrt"] = Field("straight", description="free moves (approach, transport): "
                                                "'straight' lines, or 'rrt': around obstacles where the straight "
                                                "way is blocked (docs/motion_planning.md)")
    planning: ArmPlanning = Field(default_factory=lambda: ArmPlanning.model_validate({}),
                                  description="options of planner = 'rrt'")

    @field_validator("timeouts")
    @classmethod
    def _known_states(cls, value: dict[str, float]) -> dict[str, float]:
        unknown = sorted(set(value) - set(TIMEOUTS))
        if unknown:
            raise ValueError(f"unknown state {unknown[0]!r}; states with timeouts: {', '.join(TIMEOUTS)}")
        return value


class PickPlace(MachineBehaviour):
    """Picks an object and places it at a spot: approach, descend, grasp, lift, transport, lower, release, retreat."""
    COMMANDS: ClassVar[tuple[str, ...]] = ("arm", "gripper")

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.WAIT
    TIMEOUTS = TIMEOUTS
    example: ClassVar[dict[str, Any]] = {
        "world": {"max_time": 12.0},
        "bodies": {
            "plane": {"urdf": "plane.urdf", "position": [0, 0, -0.626]},
            "table": {"urdf": "table/table.urdf", "position": [0.5, 0, -0.626], "fixed_base": True},
            "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0.5, 0.05, 0.025],
                     "rpy_deg": [0, 0, 20], "lateral_friction": 0.8},
        },
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "sensors": {"poses": {"type": "body_pose", "bodies": ["cube"]}},
        "actuators": {
            "arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget", "reach": 0.85,
                    "ready_pose": {"panda_joint1": 0.0, "panda_joint2": -0.4, "panda_joint3": 0.0,
                                   "panda_joint4": -2.2, "panda_joint5": 0.0, "panda_joint6": 1.8,
                                   "panda_joint7": 0.785}},
            "gripper": {"type": "gripper", "body": "panda", "force": 20.0, "lateral_friction": 1.2},
        },
        "config": {"pose_sensor": "poses", "object": "cube", "place_position": [0.45, -0.3, 0.027]},
    }

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config or PickPlaceConfig.model_validate({}))
        self.task: PickPlaceTask | None = None
        self.attempts = 0
        self.finished_at: float | None = None
        self.failures: list[str] = []
        self.final_position: Vec3 | None = None
        self.final_yaw: float | None = None
        self.placement_error: float | None = None
        self._entry_due = False
        self.is_sub = False
        self.jobs: list[Job] = []
        self.done: list[dict[str, Any]] = []
        self._next_due = False
        self._yaw = 0.0
        self._grasp: Vec3 = (0.0, 0.0, 0.0)
        self._arm_busy_until = -math.inf  # sim time before which the arm's path cannot have ended
        self._hold_check_due = -math.inf  # sim time of the next drop check while carrying
        self._recheck_due = -math.inf  # sim time of the next check of a planned move's rest (planning.recheck_hz)
        self._replanning = False  # the state's entry runs again to plan its move round a body that came in the way
        self._replans = 0  # replans of the running job (planning.replans)
        self._settling = False  # a retry with the object in hand: locate it only once it lies still
        self._still = 0  # steps in a row that found it still
        self.moves: Any = None  # planner = "rrt": robokit.planning.arm_moves.PlannedMoves

    # ------------------------------------------------------------------ construction
    SUB_API: ClassVar[int] = 1
    """Version of the sub-machine interface (:meth:`sub`, :meth:`start`, :meth:`step`, :meth:`halt`, ``outcome``,
    :meth:`result`); a parent asks for the version it was written against, and a robokit that no longer provides
    it refuses with a config error instead of misbehaving."""

    @classmethod
    def sub(cls, *, name: str = "pick_place", parent_ctx: SetupContext, arm: str = "arm",
            gripper: str = "gripper", max_attempts: int = 1, api: int = 1, key: str = "",
            **options: Any) -> PickPlace:
        """Build a pick-and-place sub-machine for a parent behaviour, set up with the parent's context (API 1).

        Args:
            name: The machine's name (its transitions go to the trace under ``machine=name``).
            parent_ctx: The parent's setup context.
            arm, gripper, max_attempts: As in :class:`PickPlaceConfig`.
            api: The sub-machine API version the parent was written against (see :attr:`SUB_API`).
            key: Where in the parent's config section ``options`` come from (``"pick"`` for a ``pick = {...}``
                table), so that an error names the user's key.
            **options: Further :class:`PickPlaceConfig` fields.

        Raises:
            ConfigError: An option is unknown or invalid, or ``api`` is not provided: one line, placed at ``key``
                within the parent's section (the parent's ``setup`` lets it propagate: ``robokit validate`` and
                ``run`` then exit 2).
        """
        if api != cls.SUB_API:
            raise ConfigError(f"pick_place sub-machine API version {api} does not exist; this robokit provides "
                              f"version {cls.SUB_API}", key=key)
        from robokit.config import validate_model

        fields = {"arm": arm, "gripper": gripper, "max_attempts": max_attempts, **options}
        config = validate_model(PickPlaceConfig, fields, key)
        machine = cls(name, config)
        machine.is_sub = True
        machine.setup(parent_ctx)
        return machine

    def halt(self, t: float) -> Mapping[str, Any] | None:
        """Stopped before it ended (a composite's timeout, a monitor): the arm holds where it is; the gripper
        keeps what it holds. The machine is never stepped again."""
        self.t = t
        if self.state not in (Phase.DONE, Phase.FAILED, Phase.WAIT):
            self.fire("give_up")
        return {self.config.arm: HoldArm()}

    def setup(self, ctx: SetupContext) -> None:
        """Check the arm, gripper and (top-level) pose sensor and object exist and are what they should be."""
        super().setup(ctx)
        cfg: PickPlaceConfig = self.config
        self._need(ctx, cfg.arm, "arm", ArmState, "ik_arm")
        self._need(ctx, cfg.gripper, "gripper", GripperState, "gripper")
        if cfg.pose_sensor is not None and cfg.pose_sensor not in ctx.components:
            raise ConfigError(f"no sensor named {cfg.pose_sensor!r}; add a body_pose sensor", key="pose_sensor")
        names = [("object", cfg.object)] + [(f"objects[{i}]", n) for i, n in enumerate(cfg.objects)]
        for key, name in names:
            if name is not None and not ctx.world.has_body(name):
                raise ConfigError(f"unknown body {name!r}; bodies: {', '.join(ctx.world.body_names)}", key=key)
        self.jobs = jobs_from(cfg)
        if cfg.planner == "rrt":
            from robokit.planning.arm_moves import PlannedMoves

            self.moves = PlannedMoves.for_arm(ctx.world, ctx.components[cfg.arm], ctx.rng, cfg.planning)
            for state in ("APPROACH", "TRANSPORT"):  # a way around takes longer than the straight one
                self.timeouts[state] = cfg.timeouts.get(state, PLANNED_TIMEOUT)
        if not self.is_sub:  # top-level use: the job comes from the config, so all of it must be there
            if not self.jobs:
                raise ConfigError("missing: pick_place needs the body to pick (or objects = [...], or "
                                  "pick_positions = [[x, y, z], ...])", key="object")
            for key, why in (("pose_sensor", "a body_pose sensor that sees it"),
                             ("place_position", "the object centre at the place spot, [x, y, z] m")):
                if getattr(cfg, key) is None:
                    raise ConfigError(f"missing: pick_place needs {why}", key=key)

    @staticmethod
    def _need(ctx: SetupContext, name: str, key: str, reading: type, type_name: str) -> None:
        comp = ctx.components.get(name)
        if comp is None:
            have = ", ".join(ctx.components) or "(none)"
            raise ConfigError(f"pick_place needs a {type_name} actuator named {name!r}, but there is none; "
                              f"components: {have}", key=key)
        if getattr(comp, "reading_type", None) is not reading:
            raise ConfigError(f"component {name!r} is not a {type_name} actuator", key=key)

    # ------------------------------------------------------------------ driving
    def start(self, task: PickPlaceTask, t: float) -> None:
        """Begin a new pick-and-place (resets the machine; commands follow at the next :meth:`step`)."""
        self.t = t
        if self.state not in (Phase.WAIT, Phase.DONE, Phase.FAILED):
            self.fire("give_up")  # a job still running is abandoned
        if self.state is not Phase.WAIT:
            self.fire("reset")
        self.task, self.outcome, self.attempts, self.failures = task, None, 0, []
        self._replans, self._replanning = 0, False
        self._settling, self._still = False, 0
        self._arm_busy_until = -math.inf
        self.t = self.started_at = self.entered_at = t
        self.finished_at, self.final_position, self.final_yaw, self.placement_error = None, None, None, None
        self.phase_times = {}
        self._go("begin")

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Check the state's timeout, run its ``do_<state>`` handler; return commands when a state is entered.

        A state's handler runs only after its entry commands went out, so it never sees the previous state's
        readings (e.g. an old ``reached``).
        """
        self.t = t
        if self.task is None and self.jobs or self._next_due:
            self._start_from_config(readings, t)
        name = self.state_name
        limit = self.timeouts.get(name)
        if limit is not None and self.time_in_state > limit:
            self.on_timeout(name)
        handler = self.handler("do")
        if handler is not None and self.outcome is None and not self._entry_due:
            handler(readings, t)
        if self._entry_due and self.outcome is None:
            self._entry_due = False
            enter = self.handler("enter")
            return enter(readings) if enter else None
        return None

    def _start_from_config(self, readings: Mapping[str, Any], t: float) -> None:
        """Start the next job of the config: locate its object, measure the stack on the place spot."""
        cfg: PickPlaceConfig = self.config
        if cfg.place_position is None:
            self.finish("failed", "no place_position configured")
            return
        self._next_due = False
        job = self.jobs[len(self.done)]
        poses = readings[cfg.pose_sensor] if cfg.pose_sensor is not None else {}
        name = job.object if job.position is None else identify(poses, job.position, cfg.object_size)
        self.task = PickPlaceTask(job.position or (0.0, 0.0, 0.0), 0.0, cfg.place_position, name, cfg.object_size)
        located = self._locate(readings) if name is not None or job.position is None else (job.position, 0.0)
        if located is None:
            return
        pos, yaw = located
        place = stacked_place(cfg.place_position, poses, cfg.object_size, name)
        self.start(PickPlaceTask(pos, yaw, place, name, cfg.object_size), t)

    def _locate(self, readings: Mapping[str, Any]) -> tuple[Vec3, float] | None:
        """Object centre and yaw now: from the pose sensor if there is one, else the task's."""
        cfg: PickPlaceConfig = self.config
        name = self.task.object_name if self.task else cfg.object
        if cfg.pose_sensor is None or name is None:
            return (self.task.pick_position, self.task.pick_yaw) if self.task else None
        state = readings[cfg.pose_sensor].get(name)
        if state is None:
            self._fail(f"object {name!r} is not seen by {cfg.pose_sensor!r} (removed?)")
            return None
        return tuple(state.position), yaw_of(state.orientation)  # type: ignore[return-value]

    def _go(self, trigger: str) -> None:
        if self.fire(trigger):
            self._entry_due = True
            self._arm_busy_until = self._hold_check_due = -math.inf  # the new state's commands start a new path
            self._recheck_due = -math.inf

    def _fail(self, reason: str) -> None:
        self.failures.append(reason)
        self.fire("give_up")
        self.finished_at = self.t
        if len(self.jobs) > 1 and self.task is not None:
            reason = f"object {len(self.done) + 1} of {len(self.jobs)} ({self.task.object_name or 'unknown'}): {reason}"
        self.finish("failed", reason)

    def _retry(self, reason: str) -> None:
        cfg: PickPlaceConfig = self.config
        if self.attempts >= cfg.max_attempts:
            tries = f"after {self.attempts} attempt{'s' if self.attempts > 1 else ''}"
            self._fail(f"{reason} ({tries})")  # records the failure (once: one entry per failed attempt)
        else:
            self.failures.append(reason)
            self._settling, self._still = self.state_name in CARRYING, 0  # the object may be in hand: see APPROACH
            self._go("retry")

    def on_timeout(self, state: str) -> None:
        """A state ran out of sim time: retry while attempts remain."""
        self._retry(f"timed out in {state} after {self.timeouts[state]:g} s")

    # ------------------------------------------------------------------ commands on entry
    def _move(self, pos: Vec3, slow: bool = False) -> dict[str, Any]:
        cfg: PickPlaceConfig = self.config
        return {cfg.arm: MoveTo(pos, yaw=self._yaw, speed=cfg.slow_speed if slow else cfg.speed)}

    def _free_move(self, pos: Vec3, then: Any, carrying: str | None = None, touching: str | None = None,
                   fail: bool = True) -> dict[str, Any] | None:
        """A free move (approach, transport): straight, or with ``planner = "rrt"`` around what blocks the straight
        way (``carrying``: the body held, part of the moving geometry), ending in an arm posture from which the
        straight moves on through ``then`` (down and up again) keep clear, hand, fingers and held body included
        (``touching``: the body about to be grasped). No collision-free way fails the job (None if not ``fail``)."""
        cfg: PickPlaceConfig = self.config
        if self.moves is None:
            return self._move(pos)
        cmd = self.moves.move(pos, down_quaternion(self._yaw), cfg.speed, carrying=carrying, then=then,
                              touching=touching)
        if cmd is None:
            if not fail:
                return None
            what = self.task.object_name if self.task is not None and self.task.object_name else "the object"
            self._fail(f"{what}: no collision-free way in {self.state_name}: {self.moves.last.reason}")
            return {cfg.arm: HoldArm()}
        return {cfg.arm: cmd}

    def _altitude(self) -> float:
        assert self.task is not None
        return max(self._grasp[2], self.task.place_position[2] + self.config.grasp_offset) + self.config.lift_height

    def enter_approach(self, readings: Mapping[str, Any]) -> dict[str, Any] | None:
        """Open the gripper and move above the object (located again on every attempt, once it rests)."""
        cfg: PickPlaceConfig = self.config
        if self._settling and not self._rests(readings):  # a retry with the object in hand: let go, and locate
            self._entry_due = True  # it once it lies still (falling, it would be found in the air)
            return {cfg.gripper: GripperCommand("open")}
        self._settling = False
        located = self._locate(readings)
        if located is None:
            return None
        if self._replanning:  # the same attempt, planned again
            self._replanning = False
        else:
            self.attempts += 1
        (x, y, z), yaw = located
        self._grasp = (x, y, z + cfg.grasp_offset)
        if self.moves is None:
            self._yaw = cube_grasp_yaw(yaw, 0.0)
            return {cfg.gripper: GripperCommand("open"), **self._move((x, y, self._grasp[2] + cfg.approach_height))}
        # planned: the other grasp of the cube (a quarter turn about the vertical), then a higher approach
        for rise in (1.0, 2.0):
            for turn in (0.0, math.pi / 2):
                self._yaw = cube_grasp_yaw(yaw, 0.0) + turn
                above = (x, y, self._grasp[2] + rise * cfg.approach_height)
                up = (x, y, self._altitude())
                last = rise == 2.0 and turn
                cmd = self._free_move(above, then=[self._grasp, up], touching=self.task.object_name if self.task
                                      else None, fail=bool(last))
                if cmd is not None:
                    return {cfg.gripper: GripperCommand("open"), **cmd}
        return None

    def _rests(self, readings: Mapping[str, Any]) -> bool:
        """True from the second step in a row that finds the object out of the fingers and slower than
        ``REST_SPEED`` (a body let go is still at its first instant)."""
        still = not readings[self.config.gripper].holding
        name = self.task.object_name if self.task is not None else None
        if still and self.config.pose_sensor is not None and name is not None:
            state = readings[self.config.pose_sensor].get(name)
            still = state is None or math.hypot(*state.linear_velocity) <= REST_SPEED
        self._still = self._still + 1 if still else 0
        return self._still >= 2

    def enter_descend(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Go straight down to the grasp point."""
        return self._move(self._grasp, slow=True)

    def enter_grasp(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Close the fingers with the grasp force."""
        return {self.config.gripper: GripperCommand("close", force=self.config.grasp_force)}

    def enter_lift(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Lift straight up to the transport altitude."""
        x, y, _ = self._grasp
        return self._move((x, y, self._altitude()))

    def enter_transport(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Carry the object above the place spot."""
        assert self.task is not None
        self._replanning = False
        x, y, z = self.task.place_position
        down = (x, y, z + self.config.grasp_offset + self.config.place_clearance)
        retreat = (x, y, z + self.config.grasp_offset + self.config.retreat_height)
        cmd = self._free_move((x, y, self._altitude()), then=[down, retreat], carrying=self.task.object_name)
        assert cmd is not None
        return cmd

    def enter_lower(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Lower the object to just above the place spot."""
        assert self.task is not None
        x, y, z = self.task.place_position
        return self._move((x, y, z + self.config.grasp_offset + self.config.place_clearance), slow=True)

    def enter_release(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Open the fingers a little wider than the object."""
        assert self.task is not None
        return {self.config.gripper: GripperCommand("width", width=self.task.object_size + 0.025)}

    def enter_retreat(self, readings: Mapping[str, Any]) -> dict[str, Any]:
        """Rise clear of the placed object."""
        assert self.task is not None
        x, y, z = self.task.place_position
        return self._move((x, y, z + self.config.grasp_offset + self.config.retreat_height))

    # ------------------------------------------------------------------ per-state conditions
    def _arm(self, readings: Mapping[str, Any]) -> ArmState | None:
        """The arm's reading; fails the machine if the arm rejected its target (unreachable).

        None while the arm's current path is still running (before its ``path_end``, when the arm reports one):
        it can be neither reached nor failed then, so the arm is not read at all until the path's last tick.
        """
        if self.t < self._arm_busy_until:
            return None
        arm: ArmState = readings[self.config.arm]
        if arm.failed and not self._entry_due:
            self._fail(f"arm failed in {self.state_name}: {arm.reason}")
            return None
        path_end = getattr(arm, "path_end", None)
        if arm.status == "moving" and path_end is not None:
            self._arm_busy_until = path_end - 1e-9
        return arm

    def _holding(self, readings: Mapping[str, Any]) -> bool:
        return bool(readings[self.config.gripper].holding)

    def _recheck(self) -> bool:
        """With ``planning.recheck_hz``: the rest of the planned free move checked against the world now. A body
        in its way has the state's move planned again from where the arm is (``planning.replans`` times a job),
        then fails the job. False when the move does not go on."""
        moves = self.moves
        hz = self.config.planning.recheck_hz
        if moves is None or not hz or self.t < self._recheck_due:
            return True
        self._recheck_due = self.t + 1.0 / hz
        what = moves.in_way_ahead()
        if not what:
            return True
        if self._replans < self.config.planning.replans:
            self._replans += 1
            self.moves.stats.replans += 1
            self._replanning = self._entry_due = True  # the entry plans again next step, round what is there now
            self._arm_busy_until = self._hold_check_due = -math.inf
            return False
        name = self.task.object_name if self.task is not None and self.task.object_name else "the object"
        tries = f" after {self._replans} replan{'s' if self._replans > 1 else ''}" if self._replans else ""
        self._fail(f"{name}: {what} came into the planned way in {self.state_name}; stopped{tries}")
        return False

    def do_approach(self, readings: Mapping[str, Any], t: float) -> None:
        if not self._recheck():
            return
        arm = self._arm(readings)
        if arm is not None and arm.reached:
            self._go("above_object")

    def do_descend(self, readings: Mapping[str, Any], t: float) -> None:
        arm = self._arm(readings)
        if arm is not None and arm.reached:
            self._go("at_object")

    def do_grasp(self, readings: Mapping[str, Any], t: float) -> None:
        g: GripperState = readings[self.config.gripper]
        if not g.settled or self.time_in_state < 0.02:
            return
        if g.holding:
            self._go("grasped")
        else:
            self._retry(f"grasp failed: fingers closed to {g.width * 1000:.1f} mm without holding")

    def do_lift(self, readings: Mapping[str, Any], t: float) -> None:
        self._carry(readings, "hold_verified")  # reached the transport altitude still holding: hold verified

    def do_transport(self, readings: Mapping[str, Any], t: float) -> None:
        if self._recheck():
            self._carry(readings, "above_place")

    def do_lower(self, readings: Mapping[str, Any], t: float) -> None:
        self._carry(readings, "at_place")

    def _carry(self, readings: Mapping[str, Any], trigger: str) -> None:
        """Check for a drop (every tick once the path may have ended, else at ``hold_check_hz``), then wait for
        the arm to reach its target."""
        if self.t >= self._hold_check_due or self.t >= self._arm_busy_until:
            if not self._holding(readings):
                self._retry(f"dropped during {self.state_name}")
                return
            hz = self.config.hold_check_hz
            self._hold_check_due = self.t + 1.0 / hz - 1e-9 if hz else -math.inf
        arm = self._arm(readings)
        if arm is not None and arm.reached:
            self._go(trigger)

    def do_release(self, readings: Mapping[str, Any], t: float) -> None:
        assert self.task is not None
        g: GripperState = readings[self.config.gripper]
        if g.width >= self.task.object_size + 0.01 or (g.settled and self.time_in_state > 0.05):
            self._go("released")

    def do_retreat(self, readings: Mapping[str, Any], t: float) -> None:
        arm = self._arm(readings)
        if arm is not None and arm.reached:
            self._check_placement(readings)

    def _check_placement(self, readings: Mapping[str, Any]) -> None:
        assert self.task is not None
        cfg: PickPlaceConfig = self.config
        located = self._locate(readings) if cfg.pose_sensor is not None else None
        if located is not None:
            self.final_position, self.final_yaw = located
            self.placement_error = math.dist(located[0], self.task.place_position)
            if self.placement_error > cfg.place_tolerance:
                self._retry(f"placed {self.placement_error * 1000:.0f} mm from the target")
                return
        if self.outcome is None:
            self._go("clear")
            self.finished_at = self.t
            self._job_done()

    def _job_done(self) -> None:
        """One object placed: start the next job at the next step, or succeed when none is left."""
        assert self.task is not None
        placed = f"placed {self.task.object_name or 'object'} in {self.attempts} attempt(s)"
        if len(self.jobs) <= 1:
            self.finish("succeeded", placed)
            return
        self.done.append({**self._current(), "outcome": "succeeded", "reason": placed})
        if len(self.done) < len(self.jobs):
            self._next_due = True
        else:
            attempts = sum(job["attempts"] for job in self.done)
            self.finish("succeeded", f"placed {len(self.done)} objects in {attempts} attempt(s)")

    # ------------------------------------------------------------------ preflight (before the first tick)
    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """Top-level use: the object and the place position are within the arm's reach."""
        cfg: PickPlaceConfig = self.config
        reach = getattr(ctx.components.get(cfg.arm), "check_reach", None)
        if self.is_sub or reach is None or not self.jobs or cfg.place_position is None:
            return []
        problems = []
        x, y, z = cfg.place_position
        why = reach((x, y, z + cfg.grasp_offset + cfg.place_clearance))
        if why:
            problems.append(ctx.problem(f"out of the reach of arm {cfg.arm!r}: {why}", "place_position"))
        named = len(self.jobs) - len(cfg.pick_positions)  # the jobs before pick_positions': object, objects
        for i, job in enumerate(self.jobs):
            pos = job.position or ctx.world.pose(job.object)[0]
            why = reach((pos[0], pos[1], pos[2] + cfg.grasp_offset))
            if why:
                key = ctx.body_key(job.object) if job.object else f"{ctx.key}.pick_positions[{i - named}]"
                where = f" at ({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f})" if job.object else ""  # a label has it
                problems.append(ConfigError(f"{job.label}{where} is out of the reach of arm {cfg.arm!r}: {why}",
                                            key=key))
        return problems

    # ------------------------------------------------------------------ goal (ground truth, after the run)
    def check_goal(self, world: Any) -> GoalCheck | None:
        """The object rests at its place position within ``place_tolerance``, not held (top-level use); with
        several objects, every one rests on the place spot."""
        cfg: PickPlaceConfig = self.config
        if self.is_sub or not self.jobs or cfg.place_position is None:
            return None
        robot = getattr(getattr(self.ctx.components.get(cfg.arm), "config", None), "body", None)
        if len(self.jobs) > 1:
            names = [job.get("object") for job in self.done]
            names += [job.object for job in self.jobs[len(self.done):]]
            if self.task is not None and len(self.done) < len(self.jobs):
                names[len(self.done)] = self.task.object_name
            return all_rest_on_spot(world, names, cfg.place_position, cfg.place_tolerance, robot)
        name = self.jobs[0].object or (self.task.object_name if self.task else None)
        if name is None:
            return GoalCheck(False, "the object at the pick position was never identified")
        target = self.task.place_position if self.task is not None else cfg.place_position
        return object_rests_at(world, name, target, cfg.place_tolerance, robot)

    # ------------------------------------------------------------------ result
    def result(self) -> dict[str, Any]:
        """Object, pick and place positions, final position, placement error, attempts, sim time per phase."""
        task = self.task
        end = self.finished_at if self.finished_at is not None else self.t
        return {
            "object": task.object_name if task else self.config.object,
            "outcome": self.outcome.status if self.outcome else None,
            "reason": self.outcome.reason if self.outcome else "",
            "attempts": self.attempts,
            "failures": list(self.failures),
            "pick_position": list(task.pick_position) if task else None,
            "place_position": list(task.place_position) if task else None,
            "final_position": list(self.final_position) if self.final_position else None,
            "final_yaw": self.final_yaw,
            "placement_error": self.placement_error,
            "sim_time": round(end - (self.started_at if self.started_at is not None else end), 6),
            "phase_times": {k: round(v, 6) for k, v in self.phase_times.items()},
            **({"jobs": [*self.done, *([] if len(self.done) == len(self.jobs) else [self._current()])],
                "placed": len(self.done)} if len(self.jobs) > 1 else {}),
            **({"planner": self.moves.stats.as_dict()} if self.moves is not None else {}),
        }

    def _current(self) -> dict[str, Any]:
        jobs, self.jobs = self.jobs, []  # the running job's own record, without the list
        try:
            return self.result()
        finally:
            self.jobs = jobs


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("pick_place", PickPlace, PickPlaceConfig)
