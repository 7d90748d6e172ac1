"""Tiny plugin types used by the core tests: they record the order and ticks of every call."""

from __future__ import annotations

import os
import signal
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, Behaviour, Sensor
from robokit.config import Schema

CALLS: list[tuple[str, str, int]] = []


class ProbeSensorConfig(Schema):
    body: str = "ball"
    eager: bool = False


class ProbeSensor(Sensor):
    """Reports a body's height; logs every computation."""

    reading_type = float

    def __init__(self, name: str, config: ProbeSensorConfig) -> None:
        super().__init__(name, config)
        self.lazy = not config.eager  # type: ignore[misc]

    def read(self) -> float:
        CALLS.append(("sensor", self.name, self.world.tick))
        return self.world.pose(self.config.body)[0][2]


class ProbeActuator(Actuator):
    """Pushes a body up with the commanded force (N); logs commands and updates."""

    def setup(self, ctx: Any) -> None:
        super().setup(ctx)
        self.force = 0.0

    def command(self, cmd: float) -> None:
        CALLS.append(("command", self.name, self.world.tick))
        self.force = float(cmd)

    def update(self) -> None:
        CALLS.append(("actuator", self.name, self.world.tick))
        if self.force:
            self.world.apply_force("ball", (0, 0, self.force))

    def read(self) -> float:
        return self.force


class ProbeBehaviourConfig(Schema):
    reads: tuple[str, ...] = ()
    push: float = 0.0
    finish_at: float | None = None
    sigint_at: float | None = None
    fail_at: float | None = None
    steps: int = Field(0, ge=0)


class ProbeBehaviour(Behaviour):
    """Reads the named readings, commands the pusher, and ends / raises / interrupts on cue."""

    def setup(self, ctx: Any) -> None:
        super().setup(ctx)
        self.count = 0
        self.seen: dict[str, Any] = {}

    def step(self, readings: Any, t: float) -> dict[str, Any]:
        CALLS.append(("behaviour", self.name, int(round(t * 240))))
        self.count += 1
        for name in self.config.reads:
            self.seen[name] = readings[name]
        cfg = self.config
        if cfg.fail_at is not None and t >= cfg.fail_at:
            raise RuntimeError("probe failure")
        if cfg.sigint_at is not None and t >= cfg.sigint_at:
            os.kill(os.getpid(), signal.SIGINT)
        if cfg.finish_at is not None and t >= cfg.finish_at:
            self.finish("succeeded", "probe done")
        return {"pusher": cfg.push} if cfg.push else {}

    def result(self) -> dict[str, Any]:
        return {"steps": self.count, "seen": {k: float(v) for k, v in self.seen.items()}}


class ProbePlugin:
    """Registers the probe types (pass an instance as an extra plugin)."""

    __name__ = "core_probes"

    @hookimpl
    def robokit_register_sensors(self, register: Any) -> None:
        register("probe_sensor", ProbeSensor, ProbeSensorConfig)

    @hookimpl
    def robokit_register_actuators(self, register: Any) -> None:
        register("probe_actuator", ProbeActuator, None)

    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("probe", ProbeBehaviour, ProbeBehaviourConfig)


def scene(**behaviour: Any) -> dict[str, Any]:
    """A ball on a plane, a probe sensor at 60 Hz, a pusher, and a probe behaviour with the given options."""
    return {
        "world": {"max_time": 5.0},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "ball": {"shape": "sphere", "radius": 0.05, "position": [0, 0, 0.05]}},
        "sensors": {"height": {"type": "probe_sensor", "rate_hz": 60}},
        "actuators": {"pusher": {"type": "probe_actuator"}},
        "behaviour": {"type": "probe", **behaviour},
    }
