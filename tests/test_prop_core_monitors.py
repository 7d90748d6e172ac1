"""A recovery at its own rate, and a second monitor that stops it, over generated timings (docs/behaviours.md,
"Monitors that act"; robokit/core/compose.py's ``Monitored``).

A monitor ``A`` (``recover``) fails on a generated tick; the recovery, stepped every ``period`` ticks from the next
tick, ends after a generated number of its own steps with a generated outcome, or never; a monitor ``B`` (``abort``)
aborts on a generated tick, or never. Expected, worked out plainly: the recovery's steps fall on ``a + 1 + i *
period``; if ``B`` ends while the recovery runs, the recovery is halted at that tick (its ``halt(t)`` runs once), the
actuators stop again, the run ends ``aborted`` naming both monitors, and the recovery's record says ``halted``, when
and by whom; if the recovery ends first, the run ends with its outcome (``aborted`` for a recovery that succeeded) and
its record is its own outcome and reason. The trace has the pre-emption, then the recovery's end or ``B``'s abort,
each naming the monitor, the reason and the recovery.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import SimpleNamespace
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.components import Behaviour
from robokit.core.compose import Monitored
from robokit.core.composite_base import Member

DT = 1.0 / 240.0
HORIZON = 40


class Scripted(Behaviour):
    """Ends on its step ``after + 1`` with ``outcome`` (None: never); keeps the ticks it was stepped and halted at."""

    def __init__(self, name: str, outcome: str | None, after: int) -> None:
        super().__init__(name, None)
        self.outcome_, self.after = outcome, after
        self.stepped: list[int] = []
        self.halted: list[int] = []

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        self.stepped.append(round(t / DT))
        if self.outcome_ is not None and len(self.stepped) == self.after + 1:
            self.finish(self.outcome_, f"{self.name} {self.outcome_}")
        return None

    def halt(self, t: float) -> None:
        self.halted.append(round(t / DT))

    def result(self) -> dict[str, Any]:
        return {"steps": len(self.stepped)}


class Motor:
    def __init__(self, clock: Any) -> None:
        self.clock, self.stops = clock, []  # type: list[int]

    def protective_stop(self, reason: str) -> None:
        self.stops.append(self.clock.tick)


@settings(max_examples=100, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 6), st.sampled_from([1, 2, 3]), st.sampled_from(["succeeded", "failed", "aborted", None]),
       st.integers(0, 6), st.one_of(st.none(), st.integers(1, 30)))
def test_a_recovery_at_its_rate_ended_or_stopped_by_another_monitor(a: int, period: int, rec_outcome: str | None,
                                                                     rec_after: int, b_after: int | None) -> None:
    clock = SimpleNamespace(tick=0, time_step=DT)
    motor = Motor(clock)
    task = Scripted("task", None, 0)
    mon_a = Member("A", "Scripted", Scripted("A", "failed", a), 1, "<scripted>",
                   SimpleNamespace(action="recover", recovery="again"))
    b = None if b_after is None else a + b_after  # B ends after A acted
    mon_b = Member("B", "Scripted", Scripted("B", None if b is None else "aborted", b or 0), 1, "<scripted>",
                   SimpleNamespace(action="abort"))
    rec = Member("again", "Scripted", Scripted("again", rec_outcome, rec_after), period, "<scripted>")
    trace: list[dict[str, Any]] = []
    run = Monitored(Member("task", "Scripted", task, 1, "<scripted>"), [mon_a, mon_b], clock, {"motor": motor},
                    {"again": rec}, trace=lambda kind, **data: trace.append({"kind": kind, **data}))
    end_tick = None
    for k in range(HORIZON):
        clock.tick = k
        run.step({}, k * DT)
        if run.outcome is not None:
            end_tick = k
            break

    rec_end = a + 1 + rec_after * period if rec_outcome is not None else None
    stop = b if b is not None and (rec_end is None or b < rec_end) and b < HORIZON else None
    last = min(t for t in (rec_end, stop, HORIZON - 1) if t is not None)
    assert rec.behaviour.stepped == list(range(a + 1, last + 1, period))
    preempt = {"kind": "monitor_preempt", "monitor": "A", "reason": "A failed", "recovery": "again"}
    record = run.results()["A"]["recovery"]
    assert task.halted == [a]
    if stop is not None:
        assert (end_tick, run.outcome.status) == (stop, "aborted")
        assert run.outcome.reason == (f"pre-empted at t = {a * DT:.3f} s by monitor 'A' (Scripted): A failed; "
                                      f"recovery 'again' aborted by monitor 'B' (Scripted): B aborted")
        assert rec.behaviour.halted == [stop] and motor.stops == [a, stop]
        assert trace == [preempt, {"kind": "monitor_abort", "monitor": "B", "reason": "B aborted",
                                   "recovery": "again"}]
        assert record == {"name": "again", "type": "Scripted", "outcome": "halted",
                          "reason": f"at t = {stop * DT:.3f} s by monitor 'B' (Scripted): B aborted",
                          "result": {"steps": len(rec.behaviour.stepped)}}
    elif rec_end is not None and rec_end < HORIZON:
        assert rec_outcome is not None
        status = "aborted" if rec_outcome == "succeeded" else rec_outcome
        assert (end_tick, run.outcome.status) == (rec_end, status)
        assert run.outcome.reason == (f"pre-empted at t = {a * DT:.3f} s by monitor 'A' (Scripted): A failed; "
                                      f"recovery 'again' {rec_outcome}: again {rec_outcome}")
        assert rec.behaviour.halted == [] and motor.stops == [a]
        assert trace == [preempt, {"kind": "recovery_end", "recovery": "again", "outcome": rec_outcome,
                                   "reason": f"again {rec_outcome}"}]
        assert record == {"name": "again", "type": "Scripted", "outcome": rec_outcome,
                          "reason": f"again {rec_outcome}", "result": {"steps": rec_after + 1}}
    else:
        assert end_tick is None and rec.behaviour.halted == [] and motor.stops == [a] and trace == [preempt]
        assert record == {"name": "again", "type": "Scripted", "outcome": "running", "reason": "",
                          "result": {"steps": len(rec.behaviour.stepped)}}


class Guard(Scripted):
    """A monitor that may take over from the instance that tripped (its count of steps)."""

    def __init__(self, name: str, outcome: str | None, after: int) -> None:
        super().__init__(name, outcome, after)
        self.took_over: Any = None

    def take_over(self, previous: Any) -> None:
        self.took_over = previous


class StopMotor:
    def __init__(self) -> None:
        self.reasons: list[str] = []

    def protective_stop(self, reason: str) -> None:
        self.reasons.append(reason)


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.sampled_from(["abort", "recover", "observe"]), st.sampled_from(["failed", "aborted", "succeeded"]),
       st.integers(0, 5), st.booleans(), st.booleans())
def test_what_a_monitor_that_acts_leaves_in_the_trace_results_and_stop_reasons(
        action: str, outcome: str, after: int, open_ended: bool, watch: bool) -> None:
    """A monitor ending on a generated tick with a generated outcome and action: the stop reason given to every
    actuator that has a protective stop (one without is left alone), the trace record of the abort or the
    pre-emption (and of the fresh instance that watches the recovery, which takes over from the one that tripped and
    starts the next tick), each monitor's entry in the results, and whether the run is open-ended (the task's)."""
    clock = SimpleNamespace(tick=0, time_step=DT)
    task = Scripted("task", None, 0)
    task.open_ended = open_ended  # type: ignore[attr-defined]
    spec = SimpleNamespace(action=action, recovery="again")
    mon = Member("A", "Guard", Guard("A", outcome, after), 1, "<scripted>", spec)
    quiet = Member("Q", "Scripted", Scripted("Q", None, 0), 1, "<scripted>", SimpleNamespace(action="observe"))
    rec = Member("again", "Scripted", Scripted("again", None, 0), 1, "<scripted>")
    motor, plain = StopMotor(), SimpleNamespace()
    trace: list[dict[str, Any]] = []
    run = Monitored(Member("task", "Scripted", task, 1, "<scripted>"), [mon, quiet], clock,
                    {"motor": motor, "lamp": plain}, {"again": rec},
                    trace=lambda kind, **data: trace.append({"kind": kind, **data}))
    spare = Member("A", "Guard", Guard("A", None, 0), 1, "<scripted>", spec)
    if watch:
        run.watchers["A"] = spare
    assert run.open_ended is open_ended
    assert Monitored(None, [quiet], clock).open_ended is True  # monitors alone never end by themselves
    for k in range(after + 3):
        clock.tick = k
        run.step({}, k * DT)
    acts = action != "observe" and outcome != "succeeded"
    why = f"monitor 'A' (Guard): A {outcome}"
    assert motor.reasons == ([why] if acts else [])
    entry = {"type": "Guard", "outcome": outcome, "reason": f"A {outcome}", "action": action, "steps": after + 1}
    if acts:
        entry["acted_at"] = round(after * DT, 6)
    results = run.results()
    if acts and action == "abort":
        assert trace == [{"kind": "monitor_abort", "monitor": "A", "reason": f"A {outcome}"}]
        assert (run.outcome.status, run.outcome.reason) == ("aborted", f"aborted by {why}")
    elif acts:
        assert trace[:1] == [{"kind": "monitor_preempt", "monitor": "A", "reason": f"A {outcome}",
                              "recovery": "again"}]
        assert rec.behaviour.stepped == [after + 1, after + 2] and rec.start_tick == after + 1
        entry["recovery"] = {"name": "again", "type": "Scripted", "outcome": "running", "reason": "",
                             "result": {"steps": 2}}
        if watch:
            assert trace[1:] == [{"kind": "monitor_watch", "monitor": "A", "recovery": "again"}]
            assert spare.behaviour.took_over is mon.behaviour
            assert spare.behaviour.stepped == [after + 1, after + 2]
            assert spare.behaviour.started_at == (after + 1) * DT
            entry["watch"] = {"outcome": "running", "reason": "", "steps": 2}
        else:
            assert trace[1:] == []
    else:
        assert trace == [] and run.outcome is None
    assert results["A"] == entry
    assert results["Q"] == {"type": "Scripted", "outcome": "running", "reason": "", "action": "observe",
                            "steps": after + 3}
