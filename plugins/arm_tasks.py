"""Tasks for an arm (the Panda): ``reach``, ``push`` and ``pick``, the three of panda-gym, for :mod:`robokit.gym`.

- ``reach``: bring the end effector within ``distance_threshold`` of a goal drawn in a box.
- ``push``: push an object (a cube on the table) to a goal on the table.
- ``pick``: pick an object and hold it at a goal above the table (``pick_and_place`` in panda-gym).

Positions are metres, world frame. The end effector is read from an ``ee_delta`` actuator (``ee``); objects by body
name. Goals are drawn uniformly in ``goal_low``..``goal_high`` (object starts in ``object_low``..``object_high``,
at least ``min_goal_distance`` from the goal) from the episode's generator. Observation entries: ``task.goal``,
``task.achieved`` (end effector or object), ``task.goal_delta`` (goal minus achieved); with an object also
``task.object_position``, ``object_orientation``, ``object_velocity``, ``object_angular_velocity`` and
``object_delta`` (object minus end effector). A ``goal_marker`` body, if named, is
moved to the goal and made collision-free. Dense reward is minus the distance (end effector → goal for ``reach``,
object → goal otherwise); sparse is 0 on success, -1 otherwise.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from robokit import hookimpl
from robokit.gym.task import Task, TaskConfig, TaskContext, distance, goal_reward, hide_from_collisions

Vec3 = tuple[float, float, float]


class ReachConfig(TaskConfig):
    """``[env.task]`` with ``type = "reach"``."""

    ee: str = Field("arm", description="the ee_delta actuator")
    goal_low: Vec3 = (0.35, -0.2, 0.05)
    goal_high: Vec3 = (0.65, 0.2, 0.35)
    distance_threshold: float = Field(0.05, gt=0, description="success radius, m")
    goal_marker: str | None = Field(None, description="a body moved to the goal (made collision-free)")


class ObjectTaskConfig(ReachConfig):
    """``[env.task]`` with ``type = "push"`` or ``"pick"``."""

    object: str = Field("cube", description="the body to move")
    object_low: Vec3 = (0.4, -0.15, 0.02)
    object_high: Vec3 = (0.6, 0.15, 0.02)
    min_goal_distance: float = Field(0.05, ge=0, description="m between the object's start and the goal")
    fall_height: float = Field(-0.05, description="the object below this z (m) ends the episode as failed")
    goal_on_table: float = Field(0.0, ge=0, le=1, description="probability that the goal's z is goal_low's "
                                                               "(on the table; panda-gym's pick: 0.3)")


class ReachTask(Task):
    """Reach: the end effector to a goal point drawn in a box."""

    goal_entries = frozenset({"goal", "goal_delta"})

    def setup(self, ctx: TaskContext) -> None:
        super().setup(ctx)
        cfg: ReachConfig = self.config
        ctx.component(cfg.ee, key="ee", kind="EEState")
        self.marker = ctx.body(cfg.goal_marker, key="goal_marker") if cfg.goal_marker else None
        if self.marker is not None:
            hide_from_collisions(self.world, self.marker)
        self.goal = np.zeros(3)

    def _draw_goal(self, rng: np.random.Generator) -> None:
        cfg: ReachConfig = self.config
        self.goal = rng.uniform(cfg.goal_low, cfg.goal_high)
        on_table = getattr(cfg, "goal_on_table", 0.0)
        if on_table > 0 and rng.random() < on_table:  # drawn only when asked: other tasks keep their streams
            self.goal[2] = cfg.goal_low[2]
        if self.marker is not None:
            self.world.set_pose(self.marker, self.goal.tolist())

    def reset(self, rng: np.random.Generator) -> None:
        self._draw_goal(rng)

    def achieved(self) -> Any:
        """What must reach the goal: the end-effector position."""
        return self.ctx.readings[self.config.ee].position

    def observe(self) -> dict[str, Any]:
        achieved = self.achieved()
        return {"goal": self.goal, "achieved": achieved, "goal_delta": self.goal - np.asarray(achieved)}

    def error(self) -> float:
        """Distance from the goal, m."""
        return distance(self.achieved(), self.goal)

    def reward(self) -> float:
        if self.config.reward == "sparse":
            return 0.0 if self.success() else -1.0
        return -self.error()

    def success(self) -> bool:
        return self.error() < self.config.distance_threshold

    def info(self) -> dict[str, Any]:
        return {"distance": self.error()}

    def bounds(self) -> dict[str, tuple[Any, Any]]:
        return {"goal": (self.config.goal_low, self.config.goal_high), "object_orientation": (-1.0, 1.0)}

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        return goal_reward(achieved_goal, desired_goal, self.config.distance_threshold, self.config.reward)


class PushTask(ReachTask):
    """Push: an object on the table to a goal on the table."""

    def setup(self, ctx: TaskContext) -> None:
        super().setup(ctx)
        self.object = ctx.body(self.config.object, key="object")
        self.orientation = self.world.pose(self.object)[1]

    def reset(self, rng: np.random.Generator) -> None:
        cfg: ObjectTaskConfig = self.config
        self._draw_goal(rng)
        for _ in range(1000):
            start = rng.uniform(cfg.object_low, cfg.object_high)
            if distance(start[:2], self.goal[:2]) >= cfg.min_goal_distance:
                break
        self.world.set_pose(self.object, start.tolist(), self.orientation)

    def achieved(self) -> Any:
        """What must reach the goal: the object's position."""
        return self.world.pose(self.object)[0]

    def observe(self) -> dict[str, Any]:
        (pos, orn), (lin, ang) = self.world.pose(self.object), self.world.velocity(self.object)
        ee = np.asarray(self.ctx.readings[self.config.ee].position)
        return {"goal": self.goal, "achieved": pos, "goal_delta": self.goal - np.asarray(pos),
                "object_position": pos, "object_orientation": orn, "object_velocity": lin,
                "object_angular_velocity": ang, "object_delta": np.asarray(pos) - ee}

    def failure(self) -> str | None:
        z = self.world.pose(self.object)[0][2]
        return f"{self.config.object} fell (z = {z:.3f} m)" if z < self.config.fall_height else None


class PickTask(PushTask):
    """Pick: lift an object to a goal above the table (goals reach ``goal_high`` z)."""


@hookimpl
def robokit_register_tasks(register):  # type: ignore[no-untyped-def]
    register("reach", ReachTask, ReachConfig)
    register("push", PushTask, ObjectTaskConfig)
    register("pick", PickTask, ObjectTaskConfig)
