"""Delivering into a bin: where a carried object is put down, and the straight-in docking that gets it there.

A bin is a rectangle on the floor (world xy) with a *mouth* on one side and an inward direction. A mobile robot
carrying an object at ``reach`` metres ahead of its base drives to a *stage* point in front of the mouth, turns to
face inward, and drives straight in along the bin's centre line until the object is over its *slot*; slots are
filled from the far side towards the mouth, ``spacing`` apart. Pure math, no engine.
"""

from __future__ import annotations

import math

from pydantic import Field, model_validator

from robokit.config import Schema, Vec2
from robokit.msgs.mobile import Pose2D, Twist, wrap_angle


class BinConfig(Schema):
    """A bin on the floor. Lengths in m, world frame.

    Attributes:
        area: ``[[xmin, ymin], [xmax, ymax]]``: the inside of the bin; an object whose centre is inside is in it.
        mouth: The middle of the open side, on the area's edge.
        inward_deg: Direction from the mouth into the bin, degrees (counter-clockwise from +x).
        stage_distance: The robot's base waits this far out from the mouth, facing in, before docking.
        spacing: Distance between neighbouring slots along the centre line.
        margin: Gap kept between the first slot's object and the far side.
        dock_speed: Top forward speed while docking and backing out, m/s.
    """

    area: tuple[Vec2, Vec2]
    mouth: Vec2
    inward_deg: float = 90.0
    stage_distance: float = Field(0.8, gt=0)
    spacing: float = Field(0.11, gt=0)
    margin: float = Field(0.03, ge=0)
    dock_speed: float = Field(0.12, gt=0)

    @model_validator(mode="after")
    def _shape(self) -> BinConfig:
        (x0, y0), (x1, y1) = self.area
        if x0 >= x1 or y0 >= y1:
            raise ValueError(f"bin area must be [[xmin, ymin], [xmax, ymax]], got {[list(p) for p in self.area]}")
        mx, my = self.mouth
        if not (x0 - 1e-6 <= mx <= x1 + 1e-6 and y0 - 1e-6 <= my <= y1 + 1e-6):
            raise ValueError(f"bin mouth ({mx:g}, {my:g}) is not on the bin area")
        return self


class Bin:
    """Geometry of one :class:`BinConfig` for objects of radius ``object_radius`` held ``reach`` m ahead."""

    def __init__(self, cfg: BinConfig, object_radius: float, reach: float) -> None:
        self.cfg = cfg
        self.radius = object_radius
        self.reach = reach
        a = math.radians(cfg.inward_deg)
        self.heading = wrap_angle(a)
        self.ux, self.uy = math.cos(a), math.sin(a)
        self.depth = self._depth_inside()

    def _depth_inside(self) -> float:
        """How far the area reaches from the mouth along the inward direction, m."""
        (x0, y0), (x1, y1) = self.cfg.area
        mx, my = self.cfg.mouth
        out = math.inf
        for u, m, lo, hi in ((self.ux, mx, x0, x1), (self.uy, my, y0, y1)):
            if u > 1e-9:
                out = min(out, (hi - m) / u)
            elif u < -1e-9:
                out = min(out, (lo - m) / u)
        return out

    def contains(self, x: float, y: float) -> bool:
        """True if (x, y) (world, m) lies inside the bin's area."""
        (x0, y0), (x1, y1) = self.cfg.area
        return x0 <= x <= x1 and y0 <= y <= y1

    def along(self, x: float, y: float) -> tuple[float, float]:
        """(depth past the mouth along the inward direction, signed offset from the centre line), m."""
        dx, dy = x - self.cfg.mouth[0], y - self.cfg.mouth[1]
        return dx * self.ux + dy * self.uy, -dx * self.uy + dy * self.ux

    def slot_depth(self, index: int) -> float:
        """Depth past the mouth of slot ``index`` (0 = the far one), m; never nearer the mouth than one radius."""
        first = self.depth - self.radius - self.cfg.margin
        return max(first - self.cfg.spacing * index, self.radius + self.cfg.margin)

    @property
    def stage(self) -> tuple[float, float]:
        """Where the robot's base waits before docking (world xy, m)."""
        d = self.cfg.stage_distance
        return self.cfg.mouth[0] - d * self.ux, self.cfg.mouth[1] - d * self.uy

    def held_at(self, pose: Pose2D) -> tuple[float, float]:
        """Where an object held ``reach`` m ahead of the base is (world xy, m)."""
        return pose[0] + self.reach * math.cos(pose[2]), pose[1] + self.reach * math.sin(pose[2])

    def dock(self, pose: Pose2D, slot: int, lookahead: float = 0.4) -> tuple[Twist, float]:
        """One docking step: steer onto the centre line and drive in; returns (command, depth still to go, m).

        Turns in place while the heading is more than 0.3 rad off the carrot on the centre line ``lookahead``
        m ahead; drives slower as the held object nears its slot.
        """
        held_depth, _ = self.along(*self.held_at(pose))
        left = self.slot_depth(slot) - held_depth
        base_depth, _ = self.along(pose[0], pose[1])
        carrot = base_depth + lookahead
        cx, cy = self.cfg.mouth[0] + carrot * self.ux, self.cfg.mouth[1] + carrot * self.uy
        bearing = wrap_angle(math.atan2(cy - pose[1], cx - pose[0]) - pose[2])
        omega = max(-1.0, min(1.0, 2.5 * bearing))
        if abs(bearing) > 0.3 or left <= 0.0:
            return Twist(0.0, omega if left > 0.0 else 0.0), left
        return Twist(min(self.cfg.dock_speed, 0.03 + 0.8 * left), omega), left

    def facing_error(self, pose: Pose2D) -> float:
        """Heading error from facing into the bin, rad."""
        return wrap_angle(self.heading - pose[2])
