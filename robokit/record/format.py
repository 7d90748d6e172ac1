"""Reading a run record back (``docs/records.md``); the file names and schema version are in
:mod:`robokit.record.layout`.

A run folder ``<dir>/<run_id>/`` holds ``result.json`` (the RunResult), ``trace.jsonl`` (a header line, then one
record per event) and ``poses.npz`` (the pose log). Nothing here imports pybullet.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import UserError
from robokit.record.layout import FRAMES_DIR as FRAMES_DIR  # the layout's names, re-exported for the readers
from robokit.record.layout import POSES_FILE as POSES_FILE
from robokit.record.layout import RECORD_SCHEMA as RECORD_SCHEMA
from robokit.record.layout import RESULT_FILE as RESULT_FILE
from robokit.record.layout import TRACE_FILE as TRACE_FILE
from robokit.record.layout import machines_of as machines_of


@dataclass
class Span:
    """One stay of a machine in a state: from ``start`` to ``end`` sim seconds."""

    state: str
    start: float
    end: float


@dataclass(eq=False)
class RunRecord:
    """A run folder read back. Loads lazily: the header and events on first use, poses only when asked."""

    folder: Path
    _cache: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def run_id(self) -> str:
        return self.folder.name

    @cached_property
    def result(self) -> dict[str, Any]:
        """The RunResult dict (empty if the run has none yet, e.g. it crashed)."""
        path = self.folder / RESULT_FILE
        if not path.is_file():
            return {}
        data: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
        return data

    def _no_trace(self) -> str:
        """Why there is no trace, in one line: a run with ``--no-record`` keeps only its ``result.json``."""
        if not (self.folder / RESULT_FILE).is_file():
            return f"{self.folder}: no {TRACE_FILE} (not a run record, or recorded before records existed)"
        try:
            ticks = int(self.result.get("ticks") or 0)
        except (ValueError, TypeError, json.JSONDecodeError):
            ticks = 0
        if ticks > 0:
            return (f"{self.folder}: this run kept only its {RESULT_FILE} (it ran with --no-record): there is no "
                    f"trace or pose log to draw from; run it again without --no-record")
        return f"{self.folder}: this run stopped before its record began: only its {RESULT_FILE} was kept"

    @cached_property
    def _trace(self) -> tuple[dict[str, Any], list[dict[str, Any]]]:
        path = self.folder / TRACE_FILE
        if not path.is_file():
            raise UserError(self._no_trace())
        lines = path.read_text(encoding="utf-8").splitlines()
        try:
            header = json.loads(lines[0]) if lines else {}
            events = [json.loads(line) for line in lines[1:] if line.strip()]
        except json.JSONDecodeError as exc:
            raise UserError(f"{path}: line {exc.lineno}: not JSON ({exc.msg})") from None
        if header.get("kind") != "header" or not str(header.get("schema", "")).startswith("robokit.record/"):
            raise UserError(f"{path}: the first line is not a robokit record header")
        return header, events

    @property
    def header(self) -> dict[str, Any]:
        return self._trace[0]

    @property
    def events(self) -> list[dict[str, Any]]:
        return self._trace[1]

    @property
    def has_poses(self) -> bool:
        return (self.folder / POSES_FILE).is_file()

    @cached_property
    def poses(self) -> dict[str, np.ndarray]:
        """The pose log: ``t``, ``tick``, ``base/<body>`` (N, 7) and ``joints/<body>`` (N, joints)."""
        path = self.folder / POSES_FILE
        if not path.is_file():
            if not (self.folder / TRACE_FILE).is_file():
                raise UserError(self._no_trace())
            raise UserError(f"{self.folder}: no pose log ({POSES_FILE}); was the run recorded with pose_hz = 0?")
        with np.load(path) as data:
            return {k: data[k] for k in data.files}

    @property
    def sim_time(self) -> float:
        if self.result:
            return float(self.result.get("sim_time", 0.0))
        end = [e for e in self.events if e.get("kind") == "end"]
        if end:
            return float(end[-1]["t"])
        return float(self.poses["t"][-1]) if self.has_poses and len(self.poses["t"]) else 0.0

    def spans(self) -> dict[str, list[Span]]:
        """Each machine's stays in its states, from the header's initial states and the transition records."""
        end = self.sim_time
        current = {m["name"]: (m["initial"], 0.0) for m in self.header.get("machines", [])}
        out: dict[str, list[Span]] = {name: [] for name in current}
        for e in self.events:
            if e.get("kind") != "transition":
                continue
            name = e.get("machine", "")
            state, since = current.get(name, (e["source_state"], 0.0))
            out.setdefault(name, []).append(Span(state, since, float(e["t"])))
            current[name] = (e["dest_state"], float(e["t"]))
        for name, (state, since) in current.items():
            out[name].append(Span(state, since, max(end, since)))
        return out

    def state_at(self, spans: dict[str, list[Span]], t: float) -> dict[str, str]:
        """Each machine's state at sim time ``t``."""
        out = {}
        for name, stays in spans.items():
            for s in stays:
                if s.start <= t:
                    out[name] = s.state
        return out


def results_dir(path: str | Path | None = None) -> Path:
    """The results folder: ``path`` if given, else ``./results``."""
    return Path(path) if path else Path("results")


def run_folders(root: Path) -> list[Path]:
    """Run folders under ``root``, oldest first (by modification time of the folder's trace or result)."""
    if not root.is_dir():
        return []
    found = [d for d in root.iterdir() if d.is_dir() and ((d / TRACE_FILE).is_file() or (d / RESULT_FILE).is_file())]

    def stamp(d: Path) -> float:
        f = d / TRACE_FILE if (d / TRACE_FILE).is_file() else d / RESULT_FILE
        return f.stat().st_mtime

    return sorted(found, key=lambda d: (stamp(d), d.name))


def find_run(run: str, root: str | Path | None = None) -> RunRecord:
    """A run by id, a unique prefix of one, ``last`` (the newest), or a run folder path.

    Raises:
        UserError: Nothing (or more than one run) matches.
    """
    base = results_dir(root)
    direct = Path(run)
    if direct.is_dir() and ((direct / TRACE_FILE).is_file() or (direct / RESULT_FILE).is_file()):
        return RunRecord(direct)
    runs = run_folders(base)
    if run == "last":
        if not runs:
            raise UserError(f"no runs in {base}/ yet (robokit run CONFIG keeps one there)")
        return RunRecord(runs[-1])
    matches = [d for d in runs if d.name.startswith(run)]
    if len(matches) == 1:
        return RunRecord(matches[0])
    if not matches:
        raise UserError(f"no run {run!r} in {base}/ (give a run id, a prefix of one, 'last' or a run folder)")
    raise UserError(f"run id prefix {run!r} matches {len(matches)} runs in {base}/: "
                    f"{', '.join(d.name[:12] for d in matches[:5])}{' ...' if len(matches) > 5 else ''}")
