"""``robokit results``: recent runs as a table, one run as a readable tree."""

from __future__ import annotations

import json
import os
import unicodedata
from pathlib import Path
from typing import Any

from robokit.record.format import FRAMES_DIR, POSES_FILE, RunRecord, results_dir, run_folders

_SKIP = {".git", ".venv", "venv", "node_modules", "__pycache__", "site-packages", ".mypy_cache", ".ruff_cache"}


def headline(result: dict[str, Any], limit: int = 4) -> str:
    """The first few scalar figures of a behaviour's result, as ``key=value`` pairs."""
    parts = []
    for key, value in result.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        parts.append(f"{key}={value:g}" if isinstance(value, float) else f"{key}={value}")
        if len(parts) == limit:
            break
    return " ".join(parts)


def list_runs(root: str | None, n: int = 20) -> str:
    """The newest ``n`` runs (oldest first): id, start time, config, seed, outcome, sim time, headline figures."""
    base = results_dir(root)
    folders = run_folders(base)[-n:] if n > 0 else run_folders(base)
    if not folders:
        return f"no runs in {base}/ yet (robokit run CONFIG keeps one there)"
    rows = [("run", "started (UTC)", "config", "seed", "engine", "outcome", "sim s", "figures")]
    for folder in folders:
        rec = RunRecord(folder)
        r = rec.result
        if not r:
            try:
                h = rec.header
                r = {"config": h.get("config_path", "?"), "seed": h.get("seed", "?"), "outcome": "(no result)"}
            except Exception:  # noqa: BLE001 - a broken folder is listed, not fatal
                r = {"outcome": "(unreadable)"}
        started = str(r.get("started_at", ""))[:19].replace("T", " ")
        sim = r.get("sim_time")
        rows.append((folder.name[:8], started, _short(str(r.get("config", "?"))), str(r.get("seed", "")),
                     str(r.get("engine") or "?"), str(r.get("outcome", "?")),
                     f"{sim:.2f}" if isinstance(sim, (int, float)) else "",
                     headline(r.get("result") or {})))
    widths = [max(text_width(row[i]) for row in rows) for i in range(len(rows[0]) - 1)]
    return "\n".join(("  ".join(_pad(c, w) for c, w in zip(row[:-1], widths, strict=True)) + "  " + row[-1])
                     .rstrip() for row in rows)


def text_width(text: str) -> int:
    """Columns ``text`` takes in a terminal: wide and full-width characters (Korean, Chinese, Japanese) take two,
    combining marks none."""
    return sum(0 if unicodedata.combining(ch) else 2 if unicodedata.east_asian_width(ch) in "WF" else 1
               for ch in text)


def _pad(text: str, width: int) -> str:
    return text + " " * (width - text_width(text))


def _short(path: str, width: int = 32) -> str:
    if text_width(path) <= width:
        return path
    tail = ""
    for ch in reversed(path):
        if text_width(ch + tail) > width - 3:
            break
        tail = ch + tail
    return "..." + tail


def checkout_root(start: Path | None = None) -> Path | None:
    """The checkout ``start`` (default: the current folder) is in: the nearest folder upwards with ``.git`` or
    ``pyproject.toml``; None outside any."""
    here = (start or Path.cwd()).resolve()
    for folder in (here, *here.parents):
        if (folder / ".git").exists() or (folder / "pyproject.toml").is_file():
            return folder
    return None


def other_results(looked_in: Path, start: Path | None = None, depth: int = 3) -> list[tuple[Path, int]]:
    """Other ``results`` folders of this checkout holding runs (a run started from ``configs/`` keeps its record
    in ``configs/results/``), at most ``depth`` folders below the checkout's root, with how many runs each holds.
    Outside a checkout, only the current folder's own sub-folders are looked at."""
    root = checkout_root(start)
    if root is None:
        root, depth = (start or Path.cwd()).resolve(), 1
    skip = looked_in.resolve()
    found = []
    for here, dirs, _files in os.walk(root):
        level = len(Path(here).relative_to(root).parts)
        dirs[:] = sorted(d for d in dirs if d not in _SKIP and not d.startswith(".") and level < depth)
        if "results" in dirs:
            candidate = Path(here) / "results"
            runs = len(run_folders(candidate)) if candidate.resolve() != skip else 0
            if runs:
                found.append((candidate, runs))
            dirs.remove("results")
    return found


def where_note(root: str | None, start: Path | None = None) -> str:
    """Which folder ``results list`` read (when it listed runs from it), and where else in this checkout runs were
    found, each with the command that lists them."""
    base = results_dir(root)
    lines = [f"(runs in {_shown(base)}/)"] if run_folders(base) else []
    for folder, count in other_results(base, start):
        shown = _shown(folder)
        lines.append(f"(also {count} run(s) in {shown}/: robokit results list --dir {shown})")
    return "\n".join(lines)


def _shown(path: Path) -> str:
    """``path`` relative to the current folder when it is under it, else absolute."""
    full = path.resolve()
    try:
        return str(full.relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(full)


def frames_note(folder: Path | None, asked: bool) -> str | None:
    """The line ``robokit run`` ends with when camera frames were asked for: where they went, or why there are
    none; None when nothing was asked and nothing saved."""
    frames = folder / FRAMES_DIR if folder is not None else None
    count = len(list(frames.glob("*.png"))) if frames is not None and frames.is_dir() else 0
    if count:
        return f"frames: {count} PNG(s) in {frames}/"
    if not asked:
        return None
    if folder is None:
        return "frames: none saved (--no-record keeps no run folder for them)"
    return "frames: none saved (no camera rendered a frame)"


def tree(value: Any, indent: int = 0) -> list[str]:
    """Nested dicts and lists as indented lines; scalars and short flat lists stay whole on one line."""
    pad = "  " * indent
    lines: list[str] = []
    if isinstance(value, dict):
        for key, v in value.items():
            if isinstance(v, (dict, list)) and not _flat_short(v):
                lines.append(f"{pad}{key}:")
                lines += tree(v, indent + 1)
            else:
                lines.append(f"{pad}{key}: {_scalar(v)}")
    elif isinstance(value, list):
        for i, v in enumerate(value):
            if isinstance(v, (dict, list)) and not _flat_short(v):
                lines.append(f"{pad}[{i}]")
                lines += tree(v, indent + 1)
            else:
                lines.append(f"{pad}[{i}] {_scalar(v)}")
    else:
        lines.append(f"{pad}{_scalar(value)}")
    return lines


def _flat_short(v: Any) -> bool:
    return isinstance(v, list) and all(not isinstance(x, (dict, list)) for x in v) and len(json.dumps(v)) <= 80


def _scalar(v: Any) -> str:
    return json.dumps(v, ensure_ascii=False) if isinstance(v, (list, str)) and not isinstance(v, bool) else str(v)


def show_run(rec: RunRecord) -> str:
    """One run: where its files are, the outcome and times, then the behaviour's result as a tree."""
    r = dict(rec.result)
    lines = [f"run {rec.run_id}   ({rec.folder})"]
    if not r:
        lines.append("  no result.json (the run did not finish?)")
    else:
        result = r.pop("result", {}) or {}
        for key in ("outcome", "reason", "config", "behaviour", "seed", "engine", "started_at", "sim_time",
                    "wall_time", "ticks", "robokit_version"):
            if key in r:
                version = r.get("engine_version") if key == "engine" else None
                lines.append(f"  {key}: {r[key]}" + (f" {version}" if version else ""))
        lines.append("  result:")
        lines += tree(result, 2)
    files = sorted(p.name for p in rec.folder.iterdir())
    frames = rec.folder / FRAMES_DIR
    extra = f" ({len(list(frames.glob('*.png')))} PNGs in frames/)" if frames.is_dir() else ""
    lines.append(f"  files: {', '.join(files)}{extra}")
    if (rec.folder / POSES_FILE).is_file():
        poses = rec.poses
        lines.append(f"  pose log: {len(poses['t'])} samples, {len([k for k in poses if k.startswith('base/')])} "
                     f"bodies")
    return "\n".join(lines)
