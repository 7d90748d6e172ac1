"""``drop_test`` behaviour (lesson 01): watch bodies fall, bounce and settle; record peak bounce and final pose.

The *peak bounce height* of a body is the highest its base rises after its first impact (the first time its
vertical velocity turns from falling to rising). A body that never rebounds (restitution 0) reports the height
at which it came to rest. The behaviour succeeds after ``duration`` sim seconds.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError


class DropTestConfig(Schema):
    """``pose_sensor``: a ``body_pose`` sensor's name; ``duration``: sim seconds to watch."""

    pose_sensor: str = "poses"
    duration: float = Field(5.0, gt=0)


class DropTest(Behaviour):
    """Records each body's peak bounce height and final pose (lesson 01)."""

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        if self.config.pose_sensor not in ctx.components:
            raise ConfigError(
                f"no sensor named {self.config.pose_sensor!r}; add a body_pose sensor or set pose_sensor",
                key="pose_sensor",
            )
        self.sensor = self.config.pose_sensor
        self.last_vz: dict[str, float] = {}
        self.peak: dict[str, float] = {}
        self.final: dict[str, Any] = {}

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        states = readings[self.sensor]
        last_vz, peaks = self.last_vz, self.peak
        for name, state in states.items():
            z, vz = state.position[2], state.linear_velocity[2]
            peak = peaks.get(name)
            if peak is None:
                if last_vz.get(name, 0.0) < -0.05 and vz >= 0.0:  # first impact: falling turned rising
                    peaks[name] = z
            elif z > peak:
                peaks[name] = z
            last_vz[name] = vz
        self.final.update(states)
        if self.elapsed(t) >= self.config.duration:
            self.finish("succeeded", f"watched {len(self.final)} bodies for {self.config.duration:g} s")
        return None

    def result(self) -> dict[str, Any]:
        return {
            "bodies": {
                name: {
                    "peak_bounce_height": round(self.peak.get(name, final.position[2]), 6),
                    "bounced": name in self.peak,
                    "final_position": [round(v, 6) for v in final.position],
                    "final_orientation": [round(v, 6) for v in final.orientation],
                }
                for name, final in self.final.items()
            }
        }


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("drop_test", DropTest, DropTestConfig)
