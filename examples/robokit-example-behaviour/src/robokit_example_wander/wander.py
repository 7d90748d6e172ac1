"""``wander``: drive ahead, turn away from what the lidar sees ahead, succeed after a distance travelled.

A state machine on :class:`robokit.fsm.MachineBehaviour`, written from ``docs/behaviours.md`` alone::

    DRIVE --blocked--> TURN --clear--> DRIVE      (any time: travelled --> DONE)
    DRIVE, TURN --timeout--> FAILED               (per-state sim-time timeouts, settable in the config)

Readings in: a ``LaserScan`` (``lidar``) and a ``DriveState`` (``diff_drive``); commands out: a ``Twist`` for the
``diff_drive``. Everything it imports comes from ``robokit`` (no pybullet): it can be tested with scripted readings.

Units: metres, seconds (sim time), radians; the scan's angles are counter-clockwise from the robot's heading.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from pydantic import Field
from robokit.components import SetupContext
from robokit.errors import ConfigError
from robokit.fsm import MachineBehaviour, MachineConfig
from robokit.msgs import STOP, DriveState, LaserScan, Twist


class Phase(enum.Enum):
    """States of the wander machine."""

    DRIVE = "drive"
    TURN = "turn"
    DONE = "done"
    FAILED = "failed"


TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "blocked", "source": "DRIVE", "dest": "TURN"},
    {"trigger": "clear", "source": "TURN", "dest": "DRIVE"},
    {"trigger": "travelled", "source": ["DRIVE", "TURN"], "dest": "DONE"},
    {"trigger": "give_up", "source": ["DRIVE", "TURN"], "dest": "FAILED"},
]

TIMEOUTS = {"DRIVE": 30.0, "TURN": 6.0}
"""Sim seconds per state: driving straight for 30 s, or turning for 6 s without finding a way, fails the run."""


class WanderConfig(MachineConfig):
    """``[behaviour]`` with ``type = "wander"``; ``timeouts`` (inherited) overrides ``TIMEOUTS`` per state."""

    scan: str = Field("scan", description="a lidar sensor")
    drive: str = Field("drive", description="a diff_drive actuator")
    distance: float = Field(3.0, gt=0, description="succeed after travelling this far, m")
    clearance: float = Field(0.5, gt=0, description="turn when something ahead is closer than this, m")
    sector_deg: float = Field(60.0, gt=0, le=360, description="width of the 'ahead' sector, degrees")
    speed: float = Field(0.3, gt=0, description="forward speed, m/s")
    turn_rate: float = Field(1.0, gt=0, description="turning rate in place, rad/s")


class Wander(MachineBehaviour):
    """Drives ahead, turns away from obstacles the lidar sees, and succeeds after a set distance."""

    STATES = Phase
    TRANSITIONS = TRANSITIONS
    INITIAL = Phase.DRIVE
    TIMEOUTS = TIMEOUTS
    example: ClassVar[dict[str, Any]] = {  # the scene robokit.testing.check_behaviour builds it in
        "world": {"max_time": 30.0},
        "bodies": {
            "plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
            "wall": {"shape": "box", "size": [0.2, 3.0, 0.5], "mass": 0, "position": [1.5, 0, 0.25]},
        },
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
        "sensors": {"scan": {"type": "lidar", "robot": "robot", "link": "lidar_link", "rays": 36,
                             "range_max": 3.0, "rate_hz": 10}},
        "actuators": {"drive": {"type": "diff_drive", "robot": "robot", "rate_hz": 60}},
        "config": {"distance": 2.0, "timeouts": {"TURN": 4.0}},
    }

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.turns = 0
        self.turn_direction = 1.0
        self.distance = 0.0

    def setup(self, ctx: SetupContext) -> None:
        """Check that the lidar and the drive named in the config exist and are what they should be."""
        super().setup(ctx)
        cfg: WanderConfig = self.config
        for key, name, reading in (("scan", cfg.scan, LaserScan), ("drive", cfg.drive, DriveState)):
            comp = ctx.components.get(name)
            if comp is None:
                raise ConfigError(f"no component named {name!r}; components: {', '.join(ctx.components)}", key=key)
            if getattr(comp, "reading_type", None) is not reading:
                raise ConfigError(f"{name!r} does not read a {reading.__name__}", key=key)

    # ------------------------------------------------------------------ conditions (read only)
    def nearest_ahead(self, scan: LaserScan) -> float:
        """Shortest range inside the 'ahead' sector, m (``inf`` if nothing is there)."""
        half = math.radians(self.config.sector_deg) / 2
        ahead = np.abs(scan.angles) <= half
        return float(np.min(scan.ranges[ahead])) if ahead.any() else math.inf

    def freer_side(self, scan: LaserScan) -> float:
        """+1 to turn left (counter-clockwise), -1 to turn right: the side whose returns are farther."""
        ranges = np.minimum(scan.ranges, scan.range_max)
        left, right = ranges[scan.angles > 0].mean(), ranges[scan.angles < 0].mean()
        return 1.0 if left >= right else -1.0

    def _travelled(self, readings: Mapping[str, Any]) -> bool:
        self.distance = readings[self.config.drive].distance
        if self.distance < self.config.distance:
            return False
        self.fire("travelled")
        self.finish("succeeded", f"travelled {self.distance:.2f} m with {self.turns} turn(s)")
        return True

    # ------------------------------------------------------------------ per-state handlers
    def do_drive(self, readings: Mapping[str, Any], t: float) -> dict[str, Any]:
        """Drive straight; turn towards the freer side when something is within the clearance ahead."""
        cfg: WanderConfig = self.config
        if self._travelled(readings):
            return {cfg.drive: STOP}
        scan: LaserScan = readings[cfg.scan]
        if self.nearest_ahead(scan) < cfg.clearance:
            self.turns += 1
            self.turn_direction = self.freer_side(scan)
            self.fire("blocked")
            return {cfg.drive: Twist(0.0, self.turn_direction * cfg.turn_rate)}
        return {cfg.drive: Twist(cfg.speed, 0.0)}

    def do_turn(self, readings: Mapping[str, Any], t: float) -> dict[str, Any]:
        """Turn in place until the sector ahead is clear by a margin (hysteresis: 1.5 x clearance)."""
        cfg: WanderConfig = self.config
        if self._travelled(readings):
            return {cfg.drive: STOP}
        if self.nearest_ahead(readings[cfg.scan]) > 1.5 * cfg.clearance:
            self.fire("clear")
            return {cfg.drive: Twist(cfg.speed, 0.0)}
        return {cfg.drive: Twist(0.0, self.turn_direction * cfg.turn_rate)}

    def on_timeout(self, state: str) -> None:
        """A state ran out of sim time: stop trying."""
        self.fire("give_up")
        self.finish("failed", f"timed out in {state} after {self.timeouts[state]:g} s (sim time)")

    def result(self) -> dict[str, Any]:
        """Distance travelled (m), turns made, states visited and sim seconds per state."""
        return {"distance": round(self.distance, 4), "turns": self.turns, "visited": list(self.visited),
                "phase_times": {k: round(v, 4) for k, v in self.phase_times.items()}}
