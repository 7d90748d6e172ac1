"""Composites tick by tick with scripted readings (no physics): sequence, fallback, retry, timeout, parallel, nested.

Each child is a ``Probe``: every step it sends ``{"motor": <its name>}`` (so the commands show who ran), then ends
when the scripted reading of its sensor says so. The expected tick of every start, end and halt is worked out by
hand from the rules in ``robokit/core/composites.py`` (a child that ends at tick k: the next one's first step is at
tick k + 1; a timeout halts its child at the first step where more than ``seconds`` passed since it started).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest

from robokit.checks.scripted import ScriptedRun
from robokit.components import Behaviour
from robokit.core.composites import (
    Fallback,
    FallbackConfig,
    Member,
    Parallel,
    ParallelConfig,
    Retry,
    RetryConfig,
    Sequence,
    SequenceConfig,
    Timeout,
    TimeoutConfig,
)

DT = 1 / 240


class Probe(Behaviour):
    """Sends ``{"motor": name}`` each step; ends when ``readings[name]`` is ``"ok"`` / ``"fail"`` / ``"abort"``."""

    built = 0

    def __init__(self, name: str, config: Any = None) -> None:
        super().__init__(name, config)
        Probe.built += 1
        self.steps = 0
        self.halted_at: float | None = None
        self.actuator = "motor"

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        self.steps += 1
        said = readings.get(self.name)
        if said in ("ok", "fail", "abort"):
            self.finish({"ok": "succeeded", "fail": "failed", "abort": "aborted"}[said], f"{self.name} said {said}")
        return {self.actuator: self.name}

    def halt(self, t: float) -> Mapping[str, Any]:
        self.halted_at = t
        return {self.actuator: f"{self.name} stopped"}

    def result(self) -> dict[str, Any]:
        return {"steps": self.steps}


def tree(composite: Any, *names: str, own_motors: bool = False) -> Any:
    """The composite with a Probe per name (each commanding ``motor``, or ``motor_<name>`` with own_motors)."""
    probes = [Probe(n) for n in names]
    for probe in probes:
        probe.actuator = f"motor_{probe.name}" if own_motors else "motor"
    composite.add_children([Member.of(p) for p in probes])
    return composite


def drive(run: ScriptedRun, script: Mapping[int, Mapping[str, str]], ticks: int) -> list[Any]:
    """Step ``ticks`` times; at tick k the readings are ``script.get(k, {})``. Returns each tick's motor command."""
    sent = []
    for k in range(ticks):
        if run.outcome is not None:
            break
        sent.append(run.step(script.get(k, {})).get("motor"))
    return sent


def marks(run: ScriptedRun) -> list[tuple[int, str, str]]:
    return [(r["tick"], r["kind"], r.get("child", r.get("step", ""))) for r in run.trace
            if r["kind"] in ("child_start", "child_end", "child_halt", "step_start", "step_end")]


def test_sequence_runs_children_in_order_and_stops_at_the_first_failure() -> None:
    run = ScriptedRun(tree(Sequence("seq", SequenceConfig()), "a", "b", "c"))
    sent = drive(run, {1: {"a": "ok"}, 4: {"b": "fail"}}, 10)
    # a: ticks 0-1 (ends at 1); b starts at 2, ends at 4; c never starts
    assert sent == ["a", "a", "b", "b", "b"]
    assert run.outcome is not None and run.outcome.status == "failed"
    assert run.outcome.reason == "step 2 'b' (Probe) failed: b said fail"
    assert marks(run) == [(0, "step_start", "a"), (1, "step_end", "a"), (2, "step_start", "b"), (4, "step_end", "b")]
    steps = run.result()["steps"]
    assert [(s["name"], s["outcome"]) for s in steps] == [("a", "succeeded"), ("b", "failed"), ("c", "not started")]
    assert steps[1]["started_at"] == pytest.approx(2 * DT, abs=1e-6)
    assert steps[1]["sim_time"] == pytest.approx(2 * DT, abs=1e-6)


def test_fallback_tries_alternatives_until_one_succeeds() -> None:
    run = ScriptedRun(tree(Fallback("fb", FallbackConfig()), "a", "b", "c"))
    sent = drive(run, {0: {"a": "fail"}, 3: {"b": "abort"}, 5: {"c": "ok"}}, 10)
    # a fails at 0; b runs 1-3 (aborted counts as failed); c runs 4-5 and succeeds
    assert sent == ["a", "b", "b", "b", "c", "c"]
    assert run.outcome is not None and run.outcome.status == "succeeded"
    assert run.outcome.reason == "alternative 3 'c' succeeded: c said ok"
    children = run.result()["children"]
    assert [(c["name"], c["outcome"]) for c in children] == [("a", "failed"), ("b", "aborted"), ("c", "succeeded")]


def test_fallback_fails_when_every_alternative_failed_listing_why() -> None:
    run = ScriptedRun(tree(Fallback("fb", FallbackConfig()), "a", "b"))
    drive(run, {0: {"a": "fail"}, 1: {"b": "fail"}}, 5)
    assert run.outcome is not None and run.outcome.status == "failed"
    assert run.outcome.reason == "all 2 alternatives failed (a: a said fail; b: b said fail)"


def test_retry_runs_a_fresh_child_each_attempt_and_succeeds_on_the_third() -> None:
    Probe.built = 0
    run = ScriptedRun(tree(Retry("again", RetryConfig(attempts=3)), "a"))
    sent = drive(run, {1: {"a": "fail"}, 3: {"a": "fail"}, 4: {"a": "ok"}}, 10)
    # attempt 1: ticks 0-1; attempt 2: 2-3; attempt 3: 4 (succeeds at once)
    assert sent == ["a"] * 5
    assert run.outcome is not None and run.outcome.status == "succeeded"
    assert run.outcome.reason == "attempt 3 of 3 succeeded: a said ok"
    assert Probe.built == 3  # one instance per attempt: no state carried over
    result = run.result()
    assert result["attempts"] == 3 and [c["outcome"] for c in result["children"]] == ["failed", "failed", "succeeded"]
    assert result["children"][-1]["result"] == {"steps": 1}  # the third instance stepped once


def test_retry_gives_up_after_its_attempts_with_the_last_reason() -> None:
    run = ScriptedRun(tree(Retry("again", RetryConfig(attempts=2)), "a"))
    drive(run, {0: {"a": "fail"}, 1: {"a": "abort"}}, 5)
    assert run.outcome is not None and run.outcome.status == "aborted"
    assert run.outcome.reason == "2 attempt(s) failed; last: a said abort"


def test_timeout_halts_its_child_and_fails_after_the_sim_time() -> None:
    run = ScriptedRun(tree(Timeout("limit", TimeoutConfig(seconds=0.02)), "a"))
    sent = drive(run, {}, 20)
    # 0.02 s = 4.8 ticks: the child steps at ticks 0..4 (elapsed <= 0.0167 s); at tick 5 elapsed 0.0208 s > 0.02
    assert sent == ["a"] * 5 + ["a stopped"]  # the halted child's halt() commands go out
    child = run.behaviour.children[0].behaviour
    assert child.halted_at == pytest.approx(5 * DT) and child.steps == 5
    assert run.outcome is not None and run.outcome.status == "failed"
    assert run.outcome.reason == "timed out: 'a' did not end within 0.02 s (sim time)"
    assert (5, "child_halt", "a") in marks(run)


def test_timeout_passes_on_an_outcome_reached_in_time() -> None:
    run = ScriptedRun(tree(Timeout("limit", TimeoutConfig(seconds=1.0)), "a"))
    drive(run, {3: {"a": "ok"}}, 10)
    assert run.outcome is not None and (run.outcome.status, run.outcome.reason) == ("succeeded", "a said ok")


@pytest.mark.parametrize("success,failure,script,expected", [
    ("all", "one", {2: {"a": "ok"}, 4: {"b": "ok"}}, ("succeeded", 4, "2 of 2 children succeeded")),
    ("one", "one", {2: {"a": "ok"}}, ("succeeded", 2, "1 of 2 children succeeded")),
    ("all", "one", {3: {"b": "fail"}}, ("failed", 3, "b failed: b said fail")),
    ("one", "all", {1: {"a": "fail"}, 3: {"b": "ok"}}, ("succeeded", 3, "1 of 2 children succeeded")),
    ("all", "all", {1: {"a": "fail"}, 2: {"b": "ok"}},
     ("failed", 2, "1 of 2 children succeeded; success policy 'all' not met")),
])
def test_parallel_policies(success: str, failure: str, script: dict[int, dict[str, str]],
                           expected: tuple[str, int, str]) -> None:
    run = ScriptedRun(tree(Parallel("both", ParallelConfig(success=success, failure=failure)), "a", "b",
                           own_motors=True))
    for k in range(10):
        if run.outcome is not None:
            break
        sent = run.step(script.get(k, {}))
        assert sent.get("motor_a") in (None, "a", "a stopped") and sent.get("motor_b") in (None, "b", "b stopped")
        if k == 0:
            assert sent == {"motor_a": "a", "motor_b": "b"}  # both stepped in the same tick
    status, tick, reason = expected
    assert run.outcome is not None and (run.outcome.status, run.outcome.reason) == (status, reason)
    assert run.world.tick - 1 == tick  # decided in the tick the deciding child ended
    halted = [r for r in run.trace if r["kind"] == "child_halt"]
    running = [m.name for m in run.behaviour.children if m.behaviour.outcome is None]
    assert [r["child"] for r in halted] == running  # whoever was still running was halted


def test_parallel_steps_every_child_each_tick_and_refuses_two_commands_to_one_actuator() -> None:
    from robokit.errors import PluginError

    run = ScriptedRun(tree(Parallel("both", ParallelConfig()), "a", "b"))
    with pytest.raises(PluginError, match="two children sent a command to actuator 'motor' in the same tick"):
        run.step({})


def test_composites_nest_retry_of_a_timeout_of_a_sequence() -> None:
    inner = tree(Sequence("seq", SequenceConfig()), "a", "b")
    limit = Timeout("limit", TimeoutConfig(seconds=3 * DT + 1e-6))
    limit.add_children([Member.of(inner)])
    again = Retry("again", RetryConfig(attempts=2))
    again.add_children([Member.of(limit)])
    run = ScriptedRun(again)
    # attempt 1: a runs 0..3 and is halted at tick 4 (elapsed 4 ticks > 3); attempt 2 (fresh tree) from tick 5:
    # a ends at 5, b runs 6, 7 and succeeds at 7 (elapsed 2 ticks)
    sent = drive(run, {5: {"a": "ok"}, 7: {"b": "ok"}}, 20)
    assert sent == ["a", "a", "a", "a", "a stopped", "a", "b", "b"]
    assert run.outcome is not None and run.outcome.status == "succeeded"
    assert run.outcome.reason == "attempt 2 of 2 succeeded: all 2 steps succeeded"
