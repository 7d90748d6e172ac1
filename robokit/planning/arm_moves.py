"""Moves of an ``ik_arm`` that go around obstacles: what ``pick_place`` and ``sort`` use with ``planner = "rrt"``.

:meth:`PlannedMoves.move` is asked for a tool pose. It takes the straight path the arm would take for a
:class:`~robokit.msgs.arm.MoveTo` and checks it with the engine's collision queries (the carried object
included, held where it is held now); when it is free, the command is that ``MoveTo``, as without a planner. When
it is blocked, :class:`~robokit.planning.arm.ArmPlanner` searches a joint-space path to the same final joint
configuration and the command is a :class:`~robokit.msgs.arm.FollowJoints` along it.

A move may name where the tool goes straight on from its pose (down to the cube, into the bin). The arm's posture
at the pose must then keep the links up to the wrist clear on that way too; when the straight path's last posture
does not, the arm's IK is asked again from random starts near it, and the move goes to the first posture that
does (a 7-joint arm reaches one hand pose with its elbow in many places).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.errors import ConfigError, UserError
from robokit.msgs.arm import FollowJoints, MoveTo, Quat, Vec3
from robokit.planning.arm import DEEPER, ArmPlan, ArmPlanner, ArmPlanning

if TYPE_CHECKING:
    from robokit.engines.interface import World


GOAL_TRIES = 30
"""Other arm postures tried at a move's target when the first one's way on is blocked."""
GOAL_SPREAD = 0.8
"""Spread of the random starts those postures are solved from, rad per joint (normal, about the first)."""


@dataclass
class PlanStats:
    """What the planner did in a run (a behaviour's result reports it)."""

    moves: int = 0
    straight: int = 0
    planned: int = 0
    failed: int = 0
    samples: int = 0
    checks: int = 0
    replans: int = 0
    """Free moves planned again, from where the arm was, round a body that came into the way (``recheck_hz``)."""

    def add(self, plan: ArmPlan) -> None:
        self.moves += 1
        self.straight += plan.straight
        self.planned += plan.path is not None and not plan.straight
        self.failed += plan.path is None
        self.samples += plan.samples
        self.checks += plan.checks

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)


@dataclass
class PlannedMoves:
    """Collision-free moves of one ``ik_arm`` (see the module's docstring)."""

    arm: Any
    planner: ArmPlanner
    rng: np.random.Generator
    stats: PlanStats = field(default_factory=PlanStats)
    last: ArmPlan | None = None
    in_way: str = ""

    @classmethod
    def for_arm(cls, world: World, arm: Any, rng: np.random.Generator, options: ArmPlanning | None = None,
                *, key: str = "planner") -> PlannedMoves:
        """Planned moves for an ``ik_arm`` component.

        Raises:
            ConfigError: The engine cannot check arm configurations, or the arm cannot tell its straight paths.
        """
        if not hasattr(arm, "straight_path"):
            raise ConfigError("planner 'rrt' needs an ik_arm actuator", key=key)
        try:
            world.clashes(arm.body, [], [])
        except UserError as exc:
            raise ConfigError(f"planner 'rrt' needs collision checks of arm configurations: {exc}", key=key) from None
        cols = arm.arm_cols
        planner = ArmPlanner(world, arm.body, [j.index for j in arm.arm], arm.lower[cols], arm.upper[cols],
                             options or ArmPlanning.model_validate({}))
        return cls(arm, planner, rng)

    def move(self, position: Vec3, orientation: Quat, speed: float | None, *, carrying: str | None = None,
             then: Vec3 | Sequence[Vec3] | None = None, touching: str | None = None) -> Any:
        """The command that takes the tool to a pose without a collision: a :class:`MoveTo` when the straight path
        is free (or cannot be solved: the arm then reports why), a :class:`FollowJoints` around what blocks it,
        or None when no free path was found (:attr:`last` says why). ``speed``: m/s, None = the arm's.
        ``then``: where the tool goes straight on from there (down to the cube and up again, into the bin): one
        point or a chain of them. The arm's posture at the pose is chosen so that the whole arm (hand, fingers
        and what it carries included) keeps clear on that way too; only the last ``margin`` of the first stretch,
        where the hand or the carried object meets what it grasps or is put on, is not held to the margin.
        ``touching``: a body the hand is about to grasp, not counted on that way."""
        arm, world = self.arm, self.planner.world
        straight, reason = arm.straight_path(position, orientation)
        if reason:
            return MoveTo(position, orientation, speed=speed)
        carried = []
        if carrying is not None:
            held = world.body(carrying)
            link_pose = world.pose(arm.body, arm.ee)
            rel = world.multiply_transforms(*world.invert_transform(*link_pose), *world.com_pose(held))
            carried.append((held, arm.ee, rel))
        joints = [j.index for j in arm.arm]
        self.planner.begin([s[0] for s in world.joint_states(arm.body, joints)], carried=carried)
        checks = self.planner.checks
        ways: list[Vec3] = []
        if then is not None:
            ways = [then] if isinstance(then[0], (int, float)) else list(then)  # type: ignore[list-item, arg-type]
        skip = [] if touching is None else [world.body(touching)]
        self.in_way = ""
        goal = self._goal(straight[-1], position, orientation, ways, skip)
        if goal is None:
            what = f" ({self.in_way} in the way)" if self.in_way else ""
            plan = ArmPlan(None, reason=f"no arm posture at the target whose way {'on ' if then else ''}is "
                           f"clear{what}", checks=self.planner.checks - checks)
        else:
            plan = self.planner.plan(straight[0], goal, self.rng, straight=straight if goal is straight[-1] else None)
            plan.checks = self.planner.checks - checks
        self.last = plan
        self.stats.add(plan)
        if plan.path is None:
            return None
        if plan.straight and goal is straight[-1]:
            return MoveTo(position, orientation, speed=speed)
        names = tuple(j.name for j in arm.arm)
        return FollowJoints(names, tuple(tuple(float(v) for v in q) for q in plan.path[1:]), speed=speed)

    def _goal(self, first: np.ndarray, position: Vec3, orientation: Quat, then: list[Vec3],
              skip: list[int]) -> np.ndarray | None:
        """The arm's posture with the tool at the pose: ``first`` (where the straight path ends) when it is free
        and its way on to ``then`` is clear, else one of up to ``GOAL_TRIES`` postures the arm's IK reaches from
        random starts near ``first``; None when none is."""
        if self._goal_clear(first, orientation, then, skip):
            return first
        lower, upper = self.planner.lower, self.planner.upper
        for _ in range(GOAL_TRIES):
            start = np.clip(first + self.rng.normal(0.0, GOAL_SPREAD, len(first)), lower, upper)
            path, reason = self.arm.straight_path(position, orientation, start=start)
            if not reason and self._goal_clear(path[-1], orientation, then, skip):
                return np.asarray(path[-1])
        return None

    def _goal_clear(self, q: np.ndarray, orientation: Quat, then: list[Vec3], skip: list[int]) -> bool:
        """The posture is free, and so is the whole arm (hand, fingers, what it carries) on the straight way on
        through ``then`` (``skip``: bodies not counted there; the first stretch is checked down to ``margin`` +
        ``DEEPER`` short of its end, where the hand or the carried object comes into contact)."""
        hits = self.planner.clashes(q)
        if hits:
            self.in_way = self.planner.world.body_name(hits[0].other) or f"body {hits[0].other}"
            return False
        if not self.planner.options.check_descents:
            if not then:
                return True
            way, reason = self.arm.straight_path(then[0], orientation, start=q)
            body, wrist = self.arm.body, self.arm.arm[-1].index
            return bool(reason) or self.planner.blocked(way, counts=lambda c: c.body == body and c.link < wrist) is None
        start = q
        short = self.planner.options.margin + DEEPER
        for i, point in enumerate(then):
            if i == 0:
                point = (point[0], point[1], point[2] + short)
            way, reason = self.arm.straight_path(point, orientation, start=start)
            if reason:
                return True  # the arm refuses that move itself, with its reason
            saved = self.planner.skip
            self.planner.skip = [*saved, *skip]
            try:
                hit = self.planner.blocked(way)
            finally:
                self.planner.skip = saved
            if hit is not None:
                other = hit[1][0].other
                self.in_way = self.planner.world.body_name(other) or f"body {other}"
                return False
            start = way[-1]
        return True

    def in_way_ahead(self) -> str:
        """What now stands within the margin of the rest of the last move's path (from the waypoint nearest the
        arm's measured joints on), checked against the world as it is now; "" when the rest is free."""
        plan = self.last
        if plan is None or plan.path is None:
            return ""
        world, arm = self.planner.world, self.arm
        q = np.array([s[0] for s in world.joint_states(arm.body, [j.index for j in arm.arm])])
        rest = plan.path[int(np.argmin(np.linalg.norm(plan.path - q, axis=1))):]
        hit = self.planner.blocked(list(rest))
        if hit is None:
            return ""
        other = hit[1][0].other
        return world.body_name(other) or f"body {other}"
