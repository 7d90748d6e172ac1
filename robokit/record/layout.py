"""The run record's layout (``docs/records.md``): its file names, the schema version, and the state machines' structure
the trace's header holds. The recorder (the writer) and :mod:`robokit.record.format` (the reader) both use it; it
imports nothing heavy.
"""

from __future__ import annotations

import enum
import sys
from typing import Any

RECORD_SCHEMA = "robokit.record/1"
RESULT_FILE = "result.json"
TRACE_FILE = "trace.jsonl"
POSES_FILE = "poses.npz"
FRAMES_DIR = "frames"


def machines_of(behaviour: Any) -> list[dict[str, Any]]:
    """The structure of every state machine in a behaviour (itself and machines it holds, e.g. sort's pick_place).

    Each: ``name``, ``type`` (class name), ``initial``, ``states``, ``transitions`` (trigger, source, dest) and
    ``timeouts`` (sim seconds per state).
    """
    fsm = sys.modules.get("robokit.fsm")
    if fsm is None:  # no state machine exists before robokit.fsm is imported (transitions costs ~10 ms to import)
        return []
    machine_type = fsm.MachineBehaviour
    out: list[dict[str, Any]] = []
    seen: set[int] = set()

    def visit(b: Any) -> None:
        if not isinstance(b, machine_type) or id(b) in seen:
            return
        seen.add(id(b))
        timeouts = getattr(b, "timeouts", None) or b.TIMEOUTS
        out.append({
            "name": b.name,
            "type": type(b).__name__,
            "initial": b.INITIAL.name,
            "states": [s.name for s in b.STATES],
            "transitions": [_transition(t) for t in b.TRANSITIONS],
            "timeouts": {str(k): float(v) for k, v in timeouts.items()},
        })
        for value in vars(b).values():
            visit(value)

    visit(behaviour)
    return out


def _transition(t: dict[str, Any]) -> dict[str, Any]:
    def name(s: Any) -> Any:
        if isinstance(s, (list, tuple)):
            return [name(x) for x in s]
        return s.name if isinstance(s, enum.Enum) else str(s)

    return {"trigger": t["trigger"], "source": name(t["source"]), "dest": name(t["dest"])}
