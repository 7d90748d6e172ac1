"""``go_to_goal`` behaviour (lesson 07): drive a differential-drive robot to a point, around obstacles.

Turn in place until roughly facing the goal, then drive with a smooth heading controller (yaw rate proportional to
the heading error, speed falling with the error, the clearance ahead and the distance left); with a lidar, go
around obstacles with :class:`~robokit_behaviours.avoidance.Avoider`; with ``planner = "astar"``, follow an A* path
over an occupancy grid built from the lidar with a dynamic-window local planner (:mod:`robokit.planning`).
Succeeds within ``tolerance`` of the goal; fails when ``timeout`` sim seconds pass first.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from typing import Any

from pydantic import Field
from robokit_behaviours.avoidance import MOTION_TRANSITIONS, NavConfig, Navigating
from robokit_behaviours.patrol import known_map, point_problems

from robokit import hookimpl
from robokit.components import SetupContext
from robokit.config import Vec2
from robokit.errors import ConfigError
from robokit.fsm import MachineBehaviour
from robokit.msgs.mobile import STOP


class Phase(enum.Enum):
    """States of ``go_to_goal``."""

    TURNING = "turning"
    DRIVING = "driving"
    AVOIDING = "avoiding"
    ARRIVED = "arrived"


TRANSITIONS: list[dict[str, Any]] = [
    *MOTION_TRANSITIONS,
    {"trigger": "arrived", "source": ["TURNING", "DRIVING", "AVOIDING"], "dest": "ARRIVED"},
]


class GoToGoalConfig(NavConfig):
    """``goal``: target point (x, y), m, world frame; ``timeout``: sim seconds allowed."""

    goal: Vec2
    timeout: float = Field(120.0, gt=0)


class GoToGoal(Navigating, MachineBehaviour):
    """Turn-then-drive to a goal point with lidar obstacle avoidance (lesson 07)."""

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.TURNING

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.setup_navigation(ctx)
        self.last: Any = None

    def preflight(self, ctx: SetupContext) -> list[ConfigError]:
        """The goal lies inside the world's bounds and outside the static obstacles."""
        return point_problems(ctx, [("goal", self.config.goal)], known_map(ctx, ()), self.config.drive, 0.0)

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        if self.elapsed(t) > self.config.timeout:
            self.finish("failed", f"goal not reached within {self.config.timeout:g} s (sim time)")
            return {self.config.drive: STOP}
        return super().step(readings, t)

    def _go(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        self.last = readings[self.config.drive]
        nav = self.move_towards(readings, self.config.goal, t)
        if nav.distance <= self.config.tolerance:
            self.fire("arrived")
            self.finish("succeeded", f"within {nav.distance:.3f} m of the goal at t = {t:.2f} s")
            return {self.config.drive: STOP}
        return {self.config.drive: nav.twist}

    do_turning = do_driving = do_avoiding = _go

    def result(self) -> dict[str, Any]:
        if self.last is None:
            return {}
        x, y, _ = self.last.pose
        gx, gy = self.config.goal
        return {
            "goal": list(self.config.goal),
            "final_position": [round(x, 4), round(y, 4)],
            "distance_to_goal": round(((gx - x) ** 2 + (gy - y) ** 2) ** 0.5, 4),
            "distance_travelled": round(self.last.distance, 3),
            "states": self.visited,
            **self.planning_result(),
        }


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("go_to_goal", GoToGoal, GoToGoalConfig)
