"""Test-only plugin module for sweeps: a behaviour that succeeds, raises, hangs or kills its process on a chosen
seed. Sweeps register it in every worker with ``--plugin sweep_faults`` (this folder must be on ``sys.path``)."""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema


class FaultConfig(Schema):
    """Seeds on which to misbehave, and when (sim seconds)."""

    raise_seeds: list[int] = Field(default_factory=list)
    hang_seeds: list[int] = Field(default_factory=list)
    die_seeds: list[int] = Field(default_factory=list)
    at: float = 0.05
    duration: float = 0.2


class Fault(Behaviour):
    """Succeeds after ``duration`` sim seconds, unless this run's seed is one it misbehaves on."""

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.seed = ctx.world.seed

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        if t >= self.config.at:
            if self.seed in self.config.raise_seeds:
                raise RuntimeError(f"fault injected on seed {self.seed}")
            if self.seed in self.config.hang_seeds:
                threading.Event().wait()  # blocks forever: only --trial-timeout ends this trial
            if self.seed in self.config.die_seeds:
                os._exit(17)  # the worker process dies mid-trial
        if t >= self.config.duration:
            self.finish("succeeded", f"ran {t:.3f} s")

    def result(self) -> dict[str, Any]:
        return {"seed_squared": self.seed * self.seed}


@hookimpl
def robokit_register_behaviours(register: Any) -> None:
    register("fault", Fault, FaultConfig)
