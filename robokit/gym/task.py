"""Tasks: the plugin kind that turns a scene into an episode (reward, success, termination, reset). No Gymnasium.

A task type is registered like any other plugin type::

    from robokit import hookimpl

    @hookimpl
    def robokit_register_tasks(register):
        register("reach", ReachTask, ReachConfig)     # type name, class, pydantic schema (a TaskConfig)

Lifecycle (the environment, or the ``policy`` behaviour, drives it):

1. ``__init__(name, config)`` — when the environment is made.
2. ``setup(ctx)`` — once, after the scene and its sensors and actuators are set up: look bodies up by name.
3. ``reset(rng)`` — at the start of every episode, after the world is back in its start state: place the goal
   and objects by drawing from ``rng`` (the episode's generator, seeded by ``env.reset(seed=...)``).
4. after every env step: ``observe()`` (the ``task.*`` observation entries), ``reward()``, ``success()``,
   ``failure()`` (a reason to end the episode early, or None), ``info()``.
5. ``close()``.

The episode ends (``terminated``) on success or failure, and is truncated when ``max_time`` sim seconds passed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError

if TYPE_CHECKING:
    from robokit.core.world import World


class TaskConfig(Schema):
    """Keys every task has: ``max_time`` (sim s; truncation) and ``reward`` (``dense`` = minus a distance,
    ``sparse`` = 0 on success else -1, as panda-gym)."""

    max_time: float = Field(2.0, gt=0, description="sim seconds per episode, then truncated")
    reward: Literal["dense", "sparse"] = "dense"


@dataclass
class TaskContext:
    """What a task receives in ``setup``: the World, live readings and components by name, the config folder."""

    world: World
    readings: Mapping[str, Any]
    components: Mapping[str, Any]
    config_dir: Any
    key: str = "env.task"

    def body(self, name: str, *, key: str) -> int:
        """Body id by name; a config error at ``env.task.<key>`` listing the bodies if there is none."""
        try:
            return self.world.body(name)
        except LookupNameError as exc:
            raise ConfigError(str(exc), key=f"{self.key}.{key}") from None

    def component(self, name: str, *, key: str, kind: str = "") -> Any:
        """A sensor or actuator by name (optionally of a reading type name); a config error otherwise."""
        comp = self.components.get(name)
        if comp is None or (kind and getattr(comp.reading_type, "__name__", "") != kind):
            what = f"a component with {kind} readings" if kind else "a sensor or actuator"
            raise ConfigError(f"{name!r} is not {what}; components: {', '.join(self.components)}",
                              key=f"{self.key}.{key}")
        return comp


class Task:
    """Base class of tasks. Subclasses implement :meth:`reset`, :meth:`observe`, :meth:`reward`, :meth:`success`."""

    kind: ClassVar[str] = "task"
    goal_entries: ClassVar[frozenset[str]] = frozenset()
    """Observation entries that depend on the goal (left out of a goal environment's ``observation``)."""

    def __init__(self, name: str, config: Any) -> None:
        self.name = name
        self.config = config

    def setup(self, ctx: TaskContext) -> None:
        """Look up bodies and components by name. Runs once, after the scene is built."""
        self.ctx = ctx
        self.world = ctx.world

    def reset(self, rng: np.random.Generator) -> None:
        """Place the goal and objects for a new episode, drawing only from ``rng``."""
        raise NotImplementedError

    def observe(self) -> dict[str, Any]:
        """The task's observation entries (``task.NAME`` in ``[env] observations``), e.g. ``{"goal": (x, y, z)}``."""
        return {}

    def reward(self) -> float:
        """Reward of the step that just ended."""
        raise NotImplementedError

    def success(self) -> bool:
        """True when the task is achieved now."""
        raise NotImplementedError

    def failure(self) -> str | None:
        """A reason to end the episode early as failed (an object fell off the table), or None."""
        return None

    def info(self) -> dict[str, Any]:
        """Extra per-step information (JSON-friendly numbers), merged into ``info``."""
        return {}

    def bounds(self) -> dict[str, tuple[Any, Any]]:
        """Natural bounds of observation entries by name (``{"goal": (low, high)}``); others get ``obs_limit``."""
        return {}

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        """The reward :meth:`reward` gives for these goals, vectorised over leading axes (goal tasks: for HER)."""
        raise NotImplementedError(f"task {self.name!r} has no goal: it cannot compute rewards for other goals")

    def close(self) -> None:
        """Release what the task holds."""


def hide_from_collisions(world: World, body: int) -> None:
    """Make a body a pure marker: it collides with nothing (a goal shown in the scene)."""
    world.disable_collisions(body)


def goal_reward(achieved_goal: Any, desired_goal: Any, threshold: float, kind: str) -> np.ndarray:
    """panda-gym's goal reward, vectorised over leading axes: sparse ``-1`` unless within ``threshold`` (then 0),
    dense minus the distance. float64 (as a step's reward), shape of the goals without their last axis."""
    d = np.linalg.norm(np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64), axis=-1)
    if kind == "sparse":
        return -(d >= threshold).astype(np.float64)  # type: ignore[no-any-return]
    return -d  # type: ignore[no-any-return]


def distance(a: Any, b: Any) -> float:
    """Euclidean distance of two points (any length)."""
    return math.dist(a, b)
