"""``robokit results``: recent runs as a table, one run as a readable tree."""

from __future__ import annotations

import json
from typing import Any

from robokit.record.format import FRAMES_DIR, POSES_FILE, RunRecord, results_dir, run_folders


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
    rows = [("run", "started (UTC)", "config", "seed", "outcome", "sim s", "figures")]
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
                     str(r.get("outcome", "?")), f"{sim:.2f}" if isinstance(sim, (int, float)) else "",
                     headline(r.get("result") or {})))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]) - 1)]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row[:-1], widths, strict=True)) + "  " + row[-1]
                     for row in rows)


def _short(path: str, width: int = 32) -> str:
    return path if len(path) <= width else "..." + path[-(width - 3):]


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
        for key in ("outcome", "reason", "config", "behaviour", "seed", "started_at", "sim_time", "wall_time",
                    "ticks", "robokit_version"):
            if key in r:
                lines.append(f"  {key}: {r[key]}")
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
