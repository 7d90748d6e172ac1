"""``collector`` actuator (lesson 08B): a front scoop that stows small objects in the robot's bin.

When armed, each update looks for a loose body (mass between 0 and ``max_mass``) whose centre lies in the reach
zone in front of the robot (a box in the robot's base frame). The first one found is lifted into the bin: its
collisions are switched off and a fixed constraint holds it on ``bin_link``. Finding the body by geometry is the
mechanism (what a real scoop's shape does), not perception: the reading tells the behaviour only how many objects
it holds and where the last one was taken, never which body or where others are.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema, Vec2
from robokit.msgs.mobile import Collect, CollectorState


class CollectorConfig(Schema):
    """Config of ``collector``.

    Attributes:
        robot: Body name of the robot.
        bin_link: Link the collected objects are held on.
        reach_x: Reach zone along the robot's +x, from..to, m (base frame).
        reach_half_width: Half-width of the reach zone along y, m.
        reach_height: Objects whose centre is higher than this above the base are out of reach, m.
        max_mass: Heavier bodies are not collected, kg.
        armed: Armed at the start (a :class:`Collect` command changes it).
    """

    robot: str = "robot"
    bin_link: str = "bin_link"
    reach_x: Vec2 = (0.12, 0.30)
    reach_half_width: float = Field(0.12, gt=0)
    reach_height: float = Field(0.3, gt=0)
    max_mass: float = Field(1.0, gt=0)
    armed: bool = False


class Collector(Actuator):
    """Front scoop: takes a small loose object within reach and stows it in the robot's bin."""

    reading_type = CollectorState
    example: ClassVar[dict[str, Any]] = {
        "config": {"robot": "robot", "armed": True},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "can": {"shape": "cylinder", "radius": 0.05, "height": 0.2, "mass": 0.2,
                           "position": [0.22, 0, 0.1]}},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
        "commands": [(24, Collect(False))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg = self.config
        self.body = ctx.body(cfg.robot, key="robot")
        self.bin = ctx.link(cfg.robot, cfg.bin_link, key="bin_link")
        self.armed = cfg.armed
        self.held: list[str] = []
        self.constraints: list[int] = []
        self.last_at = -1.0
        self.last_position: tuple[float, float] | None = None

    def command(self, cmd: Any) -> None:
        """Accept a :class:`Collect` (arm or disarm)."""
        if not isinstance(cmd, Collect):
            raise ValueError(f"collector takes a Collect(armed=...) command, got {cmd!r}")
        self.armed = cmd.armed

    def update(self) -> None:
        """If armed, stow the first loose object whose centre is in the reach zone."""
        if not self.armed:
            return
        name = self._in_reach()
        if name is not None:
            self._stow(name)

    def _in_reach(self) -> str | None:
        cfg = self.config
        (rx, ry, rz), orn = self.world.pose(self.body)
        yaw = self.world.euler_from_quaternion(orn)[2]
        cos, sin = math.cos(yaw), math.sin(yaw)
        for name in self.world.body_names:
            bid = self.world.body(name)
            if bid == self.body or name in self.held or not self._loose(bid):
                continue
            (x, y, z), _ = self.world.pose(bid)
            fx, fy = cos * (x - rx) + sin * (y - ry), -sin * (x - rx) + cos * (y - ry)
            if cfg.reach_x[0] <= fx <= cfg.reach_x[1] and abs(fy) <= cfg.reach_half_width and z - rz < cfg.reach_height:
                return name
        return None

    def _loose(self, bid: int) -> bool:
        mass = self.world.mass(bid)
        return 0.0 < mass <= self.config.max_mass and not self.world.joints(bid)

    def _stow(self, name: str) -> None:
        """Lift the object into the bin: collisions off, placed on the bin, held by a fixed constraint."""
        w = self.world
        bid = w.body(name)
        (x, y, _), _ = self.world.pose(bid)
        lo, hi = self.world.aabb(bid)
        slot = len(self.held)
        local = [0.04 * ((slot % 3) - 1), 0.05 * ((slot // 3) % 3 - 1), 0.005 + (hi[2] - lo[2]) / 2.0]
        w.disable_collisions(bid)
        pos, orn = w.pose(self.body, self.bin)
        world_pos, _ = w.multiply_transforms(pos, orn, local, [0, 0, 0, 1])
        w.set_com_pose(bid, world_pos, orn)
        cid = w.attach(self.body, self.bin, bid, position=local)
        self.held.append(name)
        self.constraints.append(cid)
        self.last_at = self.world.time
        self.last_position = (float(x), float(y))
        self.ctx.trace("collected", count=len(self.held))

    def read(self) -> CollectorState:
        """Armed flag, count held, and when/where the last object was taken."""
        return CollectorState(self.armed, len(self.held), self.last_at, self.last_position)

    def close(self) -> None:
        """Remove the holding constraints."""
        if self.world.closed:
            return
        for cid in self.constraints:
            try:
                self.world.detach(cid)
            except Exception:  # noqa: BLE001, S110 - the world may already be gone
                pass
        self.constraints.clear()


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("collector", Collector, CollectorConfig)
