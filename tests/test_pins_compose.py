"""Composition's promises with behaviours that only count: one clock (every step reads the world's sim time), a
sequence's next step starts on the next tick and its start is recorded, a step that does not succeed ends the
sequence, a finished monitor is stepped no more."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest
from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.testing import PLANE, make_sim

DT = 1.0 / 240.0


class CountConfig(Schema):
    """Finish with ``status`` at the ``n``-th step."""

    n: int = Field(3, ge=1)
    status: str = "succeeded"


class Counter(Behaviour):
    """Records the (local) time of each step."""

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.times: list[float] = []

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        self.times.append(t)
        if len(self.times) == self.config.n:
            self.finish(self.config.status, f"{self.config.n} steps")


class Plugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("counter", Counter, CountConfig)


def scene(behaviour: dict, **monitors: dict) -> dict:
    cfg: dict[str, Any] = {"world": {"max_time": 1.0}, "bodies": {"plane": PLANE}, "behaviour": behaviour}
    if monitors:
        cfg["monitors"] = monitors
    return cfg


def test_the_next_step_starts_on_the_next_tick_reading_the_one_clock() -> None:
    seq = {"type": "sequence", "steps": [{"type": "counter", "n": 3}, {"type": "counter", "n": 2}]}
    with make_sim(scene(seq), extra_plugins=[Plugin()]) as sim:
        result = sim.run()
        first, second = (m.behaviour for m in sim.behaviour.steps)
    assert result.outcome == "succeeded"
    assert first.times == pytest.approx([0.0, DT, 2 * DT])  # ends at tick 2
    assert second.times == pytest.approx([3 * DT, 4 * DT])  # starts at tick 3, on the world's clock
    assert first.started_at == 0.0 and second.started_at == pytest.approx(3 * DT)
    assert result.ticks == 5


@pytest.mark.parametrize("status", ["aborted", "failed"])
def test_a_step_that_does_not_succeed_ends_the_sequence(status: str) -> None:
    seq = {"type": "sequence", "steps": [{"type": "counter", "n": 2, "status": status}, {"type": "counter", "n": 2}]}
    with make_sim(scene(seq), extra_plugins=[Plugin()]) as sim:
        result = sim.run()
        second = sim.behaviour.steps[1].behaviour
    assert result.outcome == status and second.times == []


def test_a_finished_monitor_is_not_stepped_again() -> None:
    with make_sim(scene({"type": "counter", "n": 10}, watch={"type": "counter", "n": 2}),
                  extra_plugins=[Plugin()]) as sim:
        result = sim.run()
        watch = sim.monitors[0].behaviour
        task = sim.behaviour
    assert result.outcome == "succeeded" and len(task.times) == 10
    assert watch.times == pytest.approx([0.0, DT])
