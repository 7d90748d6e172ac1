"""Jobs of a top-level ``pick_place``: one object, a list of objects, or a list of known positions (lesson 06), all
placed on one spot — stacked at the height of what is already there.

Pure functions on readings and the world (no pybullet import): what to pick next, where the stack on the place spot
ends, and whether every object rests where it should (the goal). Positions are object centres, metres, world frame.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from robokit.components import GoalCheck

Vec3 = tuple[float, float, float]

REST_SPEED = 0.02
"""m/s: an object slower than this at the end of a run is resting."""
SAME_SPOT = 0.75
"""A body whose centre is within this many object sizes (horizontally) of the place spot is on the spot."""


@dataclass(frozen=True)
class Job:
    """One object to move: by body name (located by the pose sensor) or by a known position (as taught)."""

    object: str | None = None
    position: Vec3 | None = None

    @property
    def label(self) -> str:
        """The body's name, or the position it is known at."""
        if self.object is not None:
            return self.object
        assert self.position is not None
        return "object at ({:.3f}, {:.3f}, {:.3f})".format(*self.position)


def jobs_from(config: Any) -> list[Job]:
    """The jobs a config asks for, in order: ``object``, then ``objects``, then ``pick_positions``."""
    jobs = [Job(object=config.object)] if config.object is not None else []
    jobs += [Job(object=name) for name in config.objects]
    jobs += [Job(position=tuple(p)) for p in config.pick_positions]  # type: ignore[misc]
    return jobs


def identify(poses: Mapping[str, Any], position: Sequence[float], size: float) -> str | None:
    """The sensed body nearest to ``position`` within one object size (None if nothing is there)."""
    best, best_d = None, size
    for name, state in poses.items():
        d = math.dist(state.position, position)
        if d <= best_d:
            best, best_d = name, d
    return best


def stacked_place(spot: Vec3, poses: Mapping[str, Any], size: float, exclude: str | None) -> Vec3:
    """Where an object's centre goes on ``spot``: on top of whatever sensed body is already there (same size).

    ``spot`` is the centre of an object resting on the empty spot; a body within ``SAME_SPOT`` object sizes of it
    (horizontally) raises the place position to rest on that body's top.
    """
    x, y, z = spot
    top = z - size / 2
    for name, state in poses.items():
        px, py, pz = state.position
        if name != exclude and math.hypot(px - x, py - y) <= SAME_SPOT * size and pz > z - size / 2:
            top = max(top, pz + size / 2)
    return (x, y, max(z, top + size / 2))


def object_rests_at(world: Any, name: str, target: Sequence[float], tolerance: float, robot: str | None, *,
                    horizontal: bool = False) -> GoalCheck:
    """Ground truth: ``name`` rests within ``tolerance`` of ``target`` (only x, y if ``horizontal``), not touching
    the robot and slower than :data:`REST_SPEED`."""
    if not world.has_body(name):
        return GoalCheck(False, f"{name} is no longer in the world")
    pos = world.pose(name)[0]
    error = math.dist(pos[:2], target[:2]) if horizontal else math.dist(pos, target)
    speed = math.hypot(*world.velocity(name)[0])
    held = robot is not None and world.has_body(robot) and bool(
        world.contacts(world.body(name), world.body(robot)))
    details = {"object": name, "final_position": [round(v, 4) for v in pos], "placement_error": round(error, 5),
               "speed": round(speed, 4), "touching_robot": held}
    where = f"{name} is {error * 1000:.0f} mm from the place position (tolerance {tolerance * 1000:g} mm)"
    if error > tolerance:
        return GoalCheck(False, where, details)
    if held:
        return GoalCheck(False, f"{name} is at the place position but still touches the robot", details)
    if speed > REST_SPEED:
        return GoalCheck(False, f"{name} is still moving ({speed:.2f} m/s)", details)
    return GoalCheck(True, where.replace(" is ", " rests ", 1), details)


def all_rest_on_spot(world: Any, names: Sequence[str | None], spot: Vec3, tolerance: float,
                     robot: str | None) -> GoalCheck:
    """Every object rests on the place spot (horizontally within ``tolerance``: a stack may be any height)."""
    checks = [object_rests_at(world, n, spot, tolerance, robot, horizontal=True) if n is not None
              else GoalCheck(False, "an object at a pick position was never identified") for n in names]
    missed = [c.reason for c in checks if not c.met]
    details = {"objects": [dict(c.details) for c in checks]}
    if missed:
        return GoalCheck(False, f"{len(missed)} of {len(checks)} not on the place spot: {'; '.join(missed)}", details)
    return GoalCheck(True, f"all {len(checks)} objects rest on the place spot", details)
