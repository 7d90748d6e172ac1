"""``go_to`` task for a wheeled robot (``diff_drive``), for :mod:`robokit.gym`: drive to a goal on the floor.

The goal is drawn uniformly in ``goal_low``..``goal_high`` (x, y in metres, world frame), at least
``min_distance`` from the robot's start, from the episode's generator. Success: the robot's base within
``distance_threshold``. Failure: touching anything but the floor, when ``fail_on_contact`` (contacts as the drive
reports them). Observations: ``task.goal`` (x, y), ``task.goal_in_robot_frame`` (forward and left offsets, m) and
``task.bearing`` (cos, sin of the goal's direction relative to the heading). Dense reward: minus the distance.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import Field

from robokit import hookimpl
from robokit.gym.task import Task, TaskConfig, TaskContext, goal_reward, hide_from_collisions

Vec2 = tuple[float, float]


class GoToConfig(TaskConfig):
    """``[env.task]`` with ``type = "go_to"``."""

    drive: str = Field("drive", description="the diff_drive actuator")
    goal_low: Vec2 = (-1.5, -1.5)
    goal_high: Vec2 = (1.5, 1.5)
    min_distance: float = Field(0.5, ge=0, description="m from the robot's start")
    distance_threshold: float = Field(0.15, gt=0, description="success radius, m")
    fail_on_contact: bool = True
    goal_marker: str | None = Field(None, description="a body moved to the goal (made collision-free)")
    marker_height: float = Field(0.005, description="z of the marker, m")


class GoToTask(Task):
    """Go to: drive a wheeled robot's base to a goal point on the floor."""

    goal_entries = frozenset({"goal", "goal_in_robot_frame", "bearing", "distance"})

    def setup(self, ctx: TaskContext) -> None:
        super().setup(ctx)
        cfg: GoToConfig = self.config
        ctx.component(cfg.drive, key="drive", kind="DriveState")
        self.marker = ctx.body(cfg.goal_marker, key="goal_marker") if cfg.goal_marker else None
        if self.marker is not None:
            hide_from_collisions(self.world, self.marker)
        self.goal = np.zeros(2)

    def reset(self, rng: np.random.Generator) -> None:
        cfg: GoToConfig = self.config
        x, y, _ = self.ctx.readings[cfg.drive].pose
        for _ in range(1000):
            self.goal = rng.uniform(cfg.goal_low, cfg.goal_high)
            if math.hypot(self.goal[0] - x, self.goal[1] - y) >= cfg.min_distance:
                break
        if self.marker is not None:
            self.world.set_pose(self.marker, [float(self.goal[0]), float(self.goal[1]), cfg.marker_height])

    def _relative(self) -> tuple[float, float, float]:
        x, y, yaw = self.ctx.readings[self.config.drive].pose
        dx, dy = self.goal[0] - x, self.goal[1] - y
        c, s = math.cos(yaw), math.sin(yaw)
        return c * dx + s * dy, -s * dx + c * dy, math.hypot(dx, dy)

    def observe(self) -> dict[str, Any]:
        fwd, left, dist = self._relative()
        bearing = (fwd / dist, left / dist) if dist > 1e-9 else (1.0, 0.0)
        x, y, _ = self.ctx.readings[self.config.drive].pose
        return {"goal": self.goal, "achieved": (x, y), "goal_in_robot_frame": (fwd, left), "bearing": bearing,
                "distance": dist}

    def reward(self) -> float:
        if self.config.reward == "sparse":
            return 0.0 if self.success() else -1.0
        return -self._relative()[2]

    def success(self) -> bool:
        return self._relative()[2] < self.config.distance_threshold

    def failure(self) -> str | None:
        if not self.config.fail_on_contact:
            return None
        contacts = self.ctx.readings[self.config.drive].contacts
        return f"collided with {', '.join(contacts)}" if contacts else None

    def info(self) -> dict[str, Any]:
        return {"distance": self._relative()[2]}

    def bounds(self) -> dict[str, tuple[Any, Any]]:
        return {"goal": (self.config.goal_low, self.config.goal_high), "bearing": (-1.0, 1.0)}

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        return goal_reward(achieved_goal, desired_goal, self.config.distance_threshold, self.config.reward)


@hookimpl
def robokit_register_tasks(register):  # type: ignore[no-untyped-def]
    register("go_to", GoToTask, GoToConfig)
