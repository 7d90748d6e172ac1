"""Monitors against every combination of task, monitor and recovery outcomes, judged by docs/behaviours.md's rules.

A task, up to three monitors (each ``observe``, ``abort`` or ``recover``) and a recovery are scripted: each ends
after a generated number of ticks with a generated outcome, or never. The expected run is worked out below from the
docs (section 9, "Monitors that act"): a monitor acts in the tick it ends ``failed`` or ``aborted`` (the first in
declaration order, if several do), unless the task ended in that tick; ``abort`` halts the task, stops the
actuators and ends it ``aborted``; ``recover`` does the same and runs the recovery from the next tick, the run then
ending ``aborted`` when the recovery succeeds, else with the recovery's outcome; a monitor acting while the recovery
runs halts it, stops the actuators, and the run ends ``aborted``; no command goes out in a tick a monitor acts.
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
    """Ends on its step number ``after + 1`` with ``outcome`` (None: never); commands ``motor`` every step."""

    def __init__(self, name: str, outcome: str | None, after: int, commands: bool = True) -> None:
        super().__init__(name, None)
        self.outcome_, self.after, self.commands, self.steps, self.halted = outcome, after, commands, 0, []

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        self.steps += 1
        if self.outcome_ is not None and self.steps == self.after + 1:
            self.finish(self.outcome_, f"{self.name} {self.outcome_}")
        return {"motor": self.name} if self.commands else None

    def halt(self, t: float) -> None:
        self.halted.append(round(t / DT))


class Motor:
    def __init__(self) -> None:
        self.stops: list[int] = []
        self.clock: Any = None

    def protective_stop(self, reason: str) -> None:
        self.stops.append(self.clock.tick)


plan = st.tuples(st.sampled_from(["succeeded", "failed", "aborted", None]), st.integers(0, 8))
monitor = st.tuples(st.sampled_from(["observe", "abort", "recover"]), plan)


def expect(task: tuple, monitors: list[tuple], recovery: tuple) -> dict[str, Any]:
    """The run from the docs' rules, tick by tick."""
    ended: dict[int, str] = {}  # monitor index -> its outcome once ended
    phase, fired, rec_start = "task", None, None
    for k in range(HORIZON):
        if phase == "task" and task[0] is not None and task[1] == k:
            return {"outcome": task[0], "tick": k, "acted": None, "stops": [], "sent_at_end": "task"}
        if phase == "recovery" and k >= rec_start and recovery[0] is not None and k - rec_start == recovery[1]:
            status = "aborted" if recovery[0] == "succeeded" else recovery[0]
            return {"outcome": status, "tick": k, "acted": fired, "stops": [fired[1]], "sent_at_end": "recovery"}
        acting = None
        for i, (action, (outcome, after)) in enumerate(monitors):
            if i in ended or outcome is None or after != k:
                continue
            ended[i] = outcome
            if acting is None and outcome != "succeeded" and action != "observe":  # (the task runs: it did not end)
                acting = i
        if acting is None:
            continue
        action = monitors[acting][0]
        if phase == "recovery":
            return {"outcome": "aborted", "tick": k, "acted": fired, "stops": [fired[1], k], "sent_at_end": None}
        fired = (acting, k)
        if action == "abort":
            return {"outcome": "aborted", "tick": k, "acted": fired, "stops": [k], "sent_at_end": None}
        phase, rec_start = "recovery", k + 1
    return {"outcome": None, "tick": None, "acted": fired, "stops": [] if fired is None else [fired[1]],
            "sent_at_end": None}


@settings(max_examples=300, deadline=None, derandomize=True)
@given(plan, st.lists(monitor, min_size=1, max_size=3), plan)
def test_monitors_against_every_combination_of_outcomes(task: tuple, monitors: list[tuple], recovery: tuple) -> None:
    clock = SimpleNamespace(tick=0, time_step=DT)
    motor = Motor()
    motor.clock = clock
    t_beh = Scripted("task", *task)
    task_m = Member("task", "Scripted", t_beh, 1, "<scripted>")
    mons = [Member(f"m{i}", "Scripted", Scripted(f"m{i}", *p, commands=False), 1, "<scripted>",
                   SimpleNamespace(action=a, recovery="again")) for i, (a, p) in enumerate(monitors)]
    rec = Member("again", "Scripted", Scripted("again", *recovery), 1, "<scripted>")
    run = Monitored(task_m, mons, clock, {"motor": motor}, {"again": rec})
    want = expect(task, monitors, recovery)
    got_tick, sent = None, None
    for k in range(HORIZON):
        clock.tick = k
        sent = run.step({}, k * DT)
        if run.outcome is not None:
            got_tick = k
            break
    assert (run.outcome.status if run.outcome else None, got_tick) == (want["outcome"], want["tick"])
    assert motor.stops == want["stops"]  # the actuators stopped in each tick a monitor acted, and only then
    if want["acted"] is not None:
        i, k = want["acted"]
        assert t_beh.halted == [k]  # the task was halted when the monitor acted
        assert run.results()[f"m{i}"]["acted_at"] == round(k * DT, 6)
    else:
        assert t_beh.halted == []
    if want["outcome"] is not None:  # the deciding tick's commands: the ending task's or recovery's; none if a
        senders = {"task": {"motor": "task"}, "recovery": {"motor": "again"}, None: None}  # monitor acted
        assert sent == senders[want["sent_at_end"]]
