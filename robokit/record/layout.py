"""The run record's layout (``docs/records.md``): its file names, the schema version, and the state machines' structure
the trace's header holds. The recorder (the writer) and :mod:`robokit.record.format` (the reader) both use it; it
imports nothing heavy.
"""

from __future__ import annotations

import enum
import sys
from pathlib import Path
from typing import Any

RECORD_SCHEMA = "robokit.record/1"
RESULT_FILE = "result.json"
TRACE_FILE = "trace.jsonl"
POSES_FILE = "poses.npz"
FRAMES_DIR = "frames"
VIDEO_NOTE = "video.json"
"""Written into the run folder when a video of the run is made: its file, sha256 digest and frame count."""


def noted_video(folder: Path, *, undigested: bool = False) -> Path | None:
    """The MP4 the run folder's ``video.json`` names (a path relative to the folder, or absolute), when it still
    holds the bytes whose digest was noted when it was made: a video another run wrote over the same name since is
    not this run's. ``undigested``: also accept a note without a digest (written by older versions)."""
    import json

    from robokit.record.atomic import file_digest

    try:
        note = json.loads((folder / VIDEO_NOTE).read_text(encoding="utf-8"))
        path = folder / str(note["path"])
        digest = note.get("sha256")
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if path.suffix.lower() != ".mp4" or not path.is_file():
        return None
    if digest is None:
        return path if undigested else None
    try:
        return path if file_digest(path) == digest else None
    except OSError:
        return None


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
