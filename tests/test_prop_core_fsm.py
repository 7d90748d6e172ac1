"""A machine behaviour against a plain transition table, over generated runs of steps and triggers.

docs/behaviours.md and ``robokit.fsm``: ``fire`` runs a transition only from its source state and only when its
conditions hold, and says whether one ran (a self-transition counts: the state is left and entered again);
``visited`` lists every state entered, the initial one first; ``phase_times`` adds up the sim seconds spent in each
state left; ``entered_at`` / ``time_in_state`` count from the last entry (the initial state's from the machine's
first step, however late on the world's clock); a state's timeout (the class's ``TIMEOUTS`` updated by the config's
``timeouts``) fails the machine on the first step *more* than that many sim seconds after the state was entered,
naming the state, and that step's handler is not called; every change is a ``transition`` trace record.

Each example is a generated run: a start time, then steps at generated sim times with a trigger fired between
them (chosen among those the current state has, the gate open or shut). The expectation is kept here by hand: the
state, its entry time, the list of visits, the time per state and the trace, from the table written out below.
"""

from __future__ import annotations

import enum
from types import SimpleNamespace
from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.fsm import MachineBehaviour


class S(enum.Enum):
    IDLE = "idle"
    MOVE = "move"
    HOLD = "hold"
    DONE = "done"


# trigger -> source -> (dest, needs the gate open)
TABLE: dict[str, dict[str, tuple[str, bool]]] = {
    "go": {"IDLE": ("MOVE", False), "HOLD": ("MOVE", False)},
    "pause": {"MOVE": ("HOLD", False)},
    "retry": {"MOVE": ("MOVE", False), "HOLD": ("HOLD", True)},
    "jump": {"IDLE": ("DONE", True)},
    "finish": {"MOVE": ("DONE", True), "HOLD": ("DONE", False)},
}


class Machine(MachineBehaviour):
    STATES = S
    INITIAL = S.IDLE
    TRANSITIONS = [{"trigger": trig, "source": src, "dest": dest, **({"conditions": "gate"} if gated else {})}
                   for trig, rows in TABLE.items() for src, (dest, gated) in rows.items()]
    TIMEOUTS = {"MOVE": 0.5, "HOLD": 0.75}
    gate = False

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.handled: list[tuple[str, float]] = []

    def do_idle(self, readings: Any, t: float) -> Any:
        self.handled.append(("IDLE", t))
        return {"m": 0}

    def do_move(self, readings: Any, t: float) -> Any:
        self.handled.append(("MOVE", t))
        return {"m": 1}

    def do_hold(self, readings: Any, t: float) -> Any:
        self.handled.append(("HOLD", t))
        return {"m": 2}


# times are multiples of 1/8 s (exact in binary), so "more than the timeout" is decided without rounding
ticks = st.integers(0, 6).map(lambda k: k / 8)
move = st.tuples(ticks, st.sampled_from(list(TABLE)), st.booleans())
configured = st.fixed_dictionaries({}, optional={"MOVE": st.sampled_from([0.25, 1.0]),
                                                 "IDLE": st.sampled_from([0.125, 0.5])})


@settings(max_examples=20, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 16).map(lambda k: k / 8), st.lists(move, max_size=12), configured)
@example(0.125, [(0.25, "go", False), (0.25, "pause", False), (0.25, "go", False), (0.25, "pause", False),
                 (0.125, "retry", True), (0.25, "retry", True), (0.0, "finish", False)], {})  # states entered again
def test_a_machine_follows_its_table_its_clock_and_its_timeouts(start: float, moves: list, timeouts: dict) -> None:
    records: list[dict[str, Any]] = []
    m = Machine("m", SimpleNamespace(timeouts=timeouts))
    m.setup(SimpleNamespace(trace=lambda kind, **data: records.append({"kind": kind, **data})))  # type: ignore[arg-type]
    limits = {"MOVE": 0.5, "HOLD": 0.75, **timeouts}
    assert m.timeouts == limits

    state, entered, visited, trace = "IDLE", start, ["IDLE"], []
    spent: dict[str, float] = {}
    handled: list[tuple[str, float]] = []
    t = start
    for dt, trig, gate in [(0.0, None, False), *moves]:
        t += dt
        # a step at t: the state's timeout first (strictly more than its limit), then its handler
        sent = m.step({}, t)
        if state in limits and t - entered > limits[state]:
            assert m.outcome is not None and m.outcome.status == "failed"
            assert f"state {state}" in m.outcome.reason and f"{limits[state]:g} s" in m.outcome.reason
            assert sent is None and m.handled == handled
            return
        assert m.outcome is None
        if state != "DONE":
            handled.append((state, t))
            assert sent == {"m": ["IDLE", "MOVE", "HOLD"].index(state)}
        else:
            assert sent is None
        assert m.handled == handled
        assert m.time_in_state == t - entered and m.entered_at == entered
        if trig is None or state not in TABLE[trig]:
            continue
        # a trigger between steps, at the time of the last step
        m.gate = gate
        dest, gated = TABLE[trig][state]
        ran = m.fire(trig)
        assert ran is (gate or not gated)
        if ran:
            spent[state] = spent.get(state, 0.0) + (t - entered)
            trace.append({"kind": "transition", "machine": "m", "trigger": trig, "source_state": state,
                          "dest_state": dest})
            state, entered = dest, t
            visited.append(dest)
        assert (m.state_name, m.state) == (state, S[state])
        assert m.visited == visited and m.phase_times == spent and records == trace
        assert m.entered_at == entered and m.started_at == start
