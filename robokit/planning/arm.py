"""Collision-free arm motion: joint-space paths around obstacles, checked by the engine's own collision queries.

:class:`ArmPlanner` asks the World whether the arm at a configuration (and what it carries, held where it is held
now) would come closer than a margin to anything (:meth:`~robokit.engines.interface.World.clashes`); nothing is
stepped. A pair already within the margin when a move starts (the arm's base on the table) may stay as close
during that move, not come closer; every other pair counts. A move first tries the straight path it would
take anyway; only when that path is blocked does :func:`~robokit.planning.rrt.rrt_connect` search the joint space,
and the path found is shortened (:func:`~robokit.planning.rrt.shortcut`).

Units: joint values in radians (metres for prismatic joints), distances in metres.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.planning.rrt import Vector, densify, path_length, resample, rrt_connect, shortcut

if TYPE_CHECKING:  # the World is handed in; this module imports no engine
    from robokit.engines.interface import Clash, Pose, World

DEEPER = 0.002
"""How much closer (m) than at a move's start a pair already within the margin may come (contact jitter)."""


class ArmPlanning(Schema):
    """Options of arm motion planning (``planning = {...}`` beside ``planner = "rrt"``)."""

    margin: float = Field(0.01, ge=0, le=0.2, description="clearance kept from every obstacle, m (the arm tracks "
                          "its path within a few millimetres)")
    resolution: float = Field(0.02, gt=0, le=0.2, description="spacing of collision checks along a joint-space "
                              "segment, rad per joint")
    step: float = Field(0.4, gt=0, le=3.0, description="longest step of a search tree, rad (Euclidean over the "
                        "arm's joints)")
    max_samples: int = Field(3000, ge=1, le=100000, description="random samples before a search gives up")
    shortcut_rounds: int = Field(60, ge=0, le=10000, description="random shortcuts tried on a path found")
    spacing: float = Field(0.05, gt=0, le=1.0, description="spacing of the waypoints handed to the arm, rad")
    recheck_hz: float = Field(0.0, ge=0, le=1000, description="how often (sim Hz) the rest of a planned free move "
                              "is checked against the world while the arm is on it; a body that has come into its "
                              "way is planned round (see replans) or stops the job (0: never)")
    replans: int = Field(2, ge=0, le=20, description="with recheck_hz: how many times a job plans its free move "
                         "again, from where the arm is, round a body that came into its way; once they are used up "
                         "such a body stops the job (0: stop at once)")
    check_descents: bool = Field(True, description="check the whole arm (hand, fingers, held object) on the "
                                 "straight moves down and up at the cube and the bin; false: only the links up to "
                                 "the wrist on the way down (what the hand meets there is not checked)")


@dataclass
class ArmPlan:
    """One planned move.

    Attributes:
        path: Joint configurations from start to goal (rows), spaced at most ``spacing`` apart; None when no free
            path was found.
        straight: The straight path was free (no search ran).
        reason: Why there is no path ("" when there is one).
        samples: Random samples the search drew.
        checks: Configurations checked for collisions.
        length: Joint-space length of the path, rad (0 without one).
    """

    path: np.ndarray | None
    straight: bool = False
    reason: str = ""
    samples: int = 0
    checks: int = 0
    length: float = 0.0


@dataclass
class ArmPlanner:
    """Plans moves of one arm in one world.

    Args:
        world: The world whose collision queries decide.
        body: The arm's body id.
        joints: The arm's joint indices (the planning space, in this order).
        lower, upper: Their limits (rad or m).
        options: :class:`ArmPlanning`.
    """

    world: World
    body: int
    joints: Sequence[int]
    lower: np.ndarray
    upper: np.ndarray
    options: ArmPlanning = field(default_factory=lambda: ArmPlanning.model_validate({}))
    carried: list[tuple[int, int, Pose]] = field(default_factory=list)
    skip: Collection[int] = ()
    allowed: dict[tuple[int, int, int, int], float] = field(default_factory=dict)
    checks: int = 0

    def begin(self, q: Vector, *, carried: Sequence[tuple[int, int, Pose]] = (),
              skip: Collection[int] = ()) -> None:
        """Start a move from configuration ``q``: what the arm carries (``(body, link, pose)``: the carried body's
        centre-of-mass frame in the link's frame), bodies never checked, and the pairs already within the margin
        at ``q`` (the arm's base on the table), which this move may keep as close as they are, not closer."""
        self.carried, self.skip = list(carried), skip
        self.allowed = {}
        for c in self._clashes(q, self.options.margin):
            self.allowed[_pair(c)] = min(c.distance, self.allowed.get(_pair(c), c.distance))

    def _clashes(self, q: Vector, margin: float) -> list[Clash]:
        self.checks += 1
        return self.world.clashes(self.body, self.joints, [float(v) for v in q], carried=self.carried,
                                  skip=self.skip, margin=margin)

    def clashes(self, q: Vector) -> list[Clash]:
        """What the arm at ``q`` would come within the margin of, leaving out the pairs allowed for this move
        while they stay as far apart as they were at its start (within ``DEEPER``)."""
        allowed = self.allowed
        return [c for c in self._clashes(q, self.options.margin)
                if c.distance < allowed.get(_pair(c), np.inf) - DEEPER]

    def free(self, q: np.ndarray) -> bool:
        """The arm at ``q`` keeps the margin from everything but the allowed contacts."""
        return not self.clashes(q)

    def blocked(self, path: Sequence[Vector], counts: Callable[[Clash], bool] | None = None
                ) -> tuple[np.ndarray, list[Clash]] | None:
        """The first configuration along a path (straight segments, checked at ``resolution``) that is not free,
        with what it touches; None when the whole path is free. ``counts``: which clashes count (default all)."""
        for q in densify([np.asarray(p, float) for p in path], self.options.resolution):
            hits = [c for c in self.clashes(q) if counts is None or counts(c)]
            if hits:
                return q, hits
        return None

    def plan(self, start: Vector, goal: Vector, rng: np.random.Generator,
             straight: Sequence[Vector] | None = None) -> ArmPlan:
        """A free path from ``start`` to ``goal``: ``straight`` (the path the arm would take anyway, default the
        joint-space line) when it is free, else RRT-Connect's path, shortened. Call :meth:`begin` first."""
        opts = self.options
        q0, q1 = np.asarray(start, float), np.asarray(goal, float)
        first = self.checks
        line = [q0, q1] if straight is None else [np.asarray(q, float) for q in straight]
        if self.blocked(line) is None:
            path = resample(line, opts.spacing)
            return ArmPlan(path, True, checks=self.checks - first, length=path_length(list(path)))
        for name, q in (("start", q0), ("goal", q1)):
            hits = self.clashes(q)
            if hits:
                what = self.world.body_name(hits[0].other) or f"body {hits[0].other}"
                return ArmPlan(None, reason=f"the {name} configuration is within {opts.margin:g} m of {what}",
                               checks=self.checks - first)
        search = rrt_connect(q0, q1, lower=self.lower, upper=self.upper, free=self.free, rng=rng, step=opts.step,
                             resolution=opts.resolution, max_samples=opts.max_samples)
        if search.path is None:
            return ArmPlan(None, reason=f"no collision-free path found in {opts.max_samples} samples",
                           samples=search.samples, checks=self.checks - first)
        short = shortcut(search.path, self.free, rng, resolution=opts.resolution, rounds=opts.shortcut_rounds)
        path = resample(short, opts.spacing)
        return ArmPlan(path, False, samples=search.samples, checks=self.checks - first,
                       length=path_length(list(path)))


def _pair(c: Clash) -> tuple[int, int, int, int]:
    return (c.body, c.link, c.other, c.other_link)
