"""Aggregating trial rows: per cell, the success rate with a 95 % Wilson interval and median / p95 of figures.

Also the outputs made from the summary: Markdown, JUnit XML (one test case per trial) and PNG plots.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

Z95 = 1.959963984540054


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a success rate (95 % by default); (0, 1) when there are no trials.

    Always ``0 <= low <= successes / n <= high <= 1``: computed in floating point the bounds can land a hair on
    the wrong side (``wilson(10, 10)`` gave an upper bound of 0.9999999999999999, below the rate itself), so they
    are clamped here, where they are made.
    """
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return min(max(0.0, centre - half), p), max(min(1.0, centre + half), p)


def error_bars(rate: float, low: float, high: float) -> tuple[float, float]:
    """The (below, above) error bar lengths of ``rate`` within ``[low, high]``, never negative."""
    return max(0.0, rate - low), max(0.0, high - rate)


def percentile(values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile, q in 0..100 (p95 of 20 values is the 19th smallest)."""
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, math.ceil(q / 100.0 * len(ordered)) - 1))
    return ordered[k]


def _numeric(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


ROW_FIGURES = ("sim_time", "wall_time")
"""Figures every row carries beside its result's figures (aggregated for every cell, named or not)."""


def _figure(row: Mapping[str, Any], name: str) -> Any:
    """The value of figure ``name`` in a row: the result's own figure of that name first, else the row's."""
    figures = row.get("figures", {})
    if name in figures:
        return figures[name]
    return row.get(name) if name in ROW_FIGURES else None


def _engine(row: Mapping[str, Any]) -> str:
    """The engine (and version) a trial ran on, as its row names it ("?" for a row that does not)."""
    return " ".join(str(v) for v in (row.get("engine"), row.get("engine_version")) if v) or "?"


def summarise(rows: Sequence[Mapping[str, Any]], cells: Sequence[str], metrics: Sequence[str] = ()) -> dict[str, Any]:
    """The summary of a sweep's rows, cell by cell (in ``cells`` order).

    Args:
        rows: Finished trials (rows of ``trials.jsonl``).
        cells: The cell keys in the sweep's order.
        metrics: Figures to aggregate; empty = every numeric figure any row has.
    """
    names = list(metrics) or sorted({k for r in rows for k, v in r.get("figures", {}).items() if _numeric(v)})
    out_cells = []
    for cell in cells:
        mine = [r for r in rows if r["cell"] == cell]
        ok = sum(r["outcome"] == "succeeded" for r in mine)
        lo, hi = wilson(ok, len(mine))
        figures: dict[str, Any] = {}
        for name in dict.fromkeys([*names, *ROW_FIGURES]):  # a metric named sim_time is aggregated once
            values = [_figure(r, name) for r in mine]
            nums = [float(v) for v in values if v is not None and _numeric(v)]
            if nums:
                figures[name] = {"n": len(nums), "median": statistics.median(nums), "p95": percentile(nums, 95)}
        out_cells.append({
            "cell": cell, "overrides": mine[0]["overrides"] if mine else {}, "trials": len(mine),
            "engine": ", ".join(sorted({_engine(r) for r in mine if r.get("engine")})) or "?",
            "succeeded": ok, "errors": sum(r["outcome"] == "error" for r in mine),
            "success_rate": ok / len(mine) if mine else None, "wilson95": [lo, hi], "figures": figures,
        })
    total = len(rows)
    ok = sum(r["outcome"] == "succeeded" for r in rows)
    return {"schema": "robokit.sweep.summary/1", "trials": total, "succeeded": ok,
            "errors": sum(r["outcome"] == "error" for r in rows), "wilson95": list(wilson(ok, total)),
            "metrics": names, "cells": out_cells}


def toml_literal(value: Any) -> str:
    """A value as TOML writes it (what ``--set KEY=VALUE`` reads back to the same value)."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):  # TOML has no surrogate pairs: characters as they are, DEL and controls escaped
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k} = {toml_literal(v)}" for k, v in value.items()) + "}"
    return toml_literal(str(value))


def reproduce_command(config: str, seed: int, overrides: Mapping[str, Any]) -> str:
    """The ``robokit run`` command line that runs one trial alone (its config, seed and overrides), shell-quoted."""
    import shlex

    parts = ["robokit", "run", shlex.quote(config), "--seed", str(seed)]
    for key, value in overrides.items():
        parts += ["--set", shlex.quote(f"{key}={toml_literal(value)}")]
    return " ".join(parts)


def failed_trials(rows: Sequence[Mapping[str, Any]], config: str) -> list[dict[str, Any]]:
    """Every trial that did not succeed: key, outcome, reason, the command that reproduces it, its kept record."""
    return [{"key": r["key"], "cell": r["cell"], "seed": r["seed"], "outcome": r["outcome"], "reason": r["reason"],
             "command": reproduce_command(config, int(r["seed"]), r.get("overrides", {})),
             "record": r.get("record")} for r in rows if r["outcome"] != "succeeded"]


def _fmt(value: float) -> str:
    return f"{value:.4g}"


def to_markdown(summary: Mapping[str, Any]) -> str:
    """The summary as a Markdown table: one row per cell, ``median / p95`` per figure."""
    names = list(dict.fromkeys([*summary["metrics"], "sim_time"]))
    head = ["cell", "engine", "trials", "success", "95 % CI", "errors", *(f"{n} (median / p95)" for n in names)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in summary["cells"]:
        rate = "-" if c["success_rate"] is None else f"{100 * c['success_rate']:.1f} %"
        lo, hi = c["wilson95"]
        cols = [f"`{c['cell']}`", c.get("engine") or "?", str(c["trials"]), rate, f"{100 * lo:.1f}–{100 * hi:.1f} %",
                str(c["errors"])]
        for n in names:
            f = c["figures"].get(n)
            cols.append(f"{_fmt(f['median'])} / {_fmt(f['p95'])}" if f else "-")
        lines.append("| " + " | ".join(cols) + " |")
    lo, hi = summary["wilson95"]
    lines.append("")
    lines.append(f"{summary['trials']} trials, {summary['succeeded']} succeeded, {summary['errors']} errors "
                 f"(success 95 % CI {100 * lo:.1f}–{100 * hi:.1f} %).")
    failed = summary.get("failed_trials") or []
    if failed:
        lines += ["", f"Trials that did not succeed ({len(failed)}):", ""]
        for f in failed[:MAX_LISTED]:
            lines.append(f"- `{f['key']}`: {f['outcome']}: {f['reason'] or '(no reason given)'}")
            lines.append(f"  reproduce: `{f['command']}`" + (f"; record: {f['record']}" if f.get("record") else ""))
        if len(failed) > MAX_LISTED:
            lines.append(f"- ... and {len(failed) - MAX_LISTED} more (every one is in summary.json)")
    return "\n".join(lines) + "\n"


MAX_LISTED = 50
"""Failed trials listed in the Markdown table's footer (summary.json lists them all)."""


def write_junit(rows: Sequence[Mapping[str, Any]], path: Path, name: str = "robokit sweep") -> None:
    """JUnit XML: one test case per trial (``failed``/``aborted`` are failures, ``error`` is an error)."""
    suite = ET.Element("testsuite", name=name, tests=str(len(rows)),
                       failures=str(sum(r["outcome"] in ("failed", "aborted") for r in rows)),
                       errors=str(sum(r["outcome"] == "error" for r in rows)),
                       time=f"{sum(float(r.get('wall_time') or 0) for r in rows):.3f}")
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname=r["cell"], name=f"seed={r['seed']}",
                             time=f"{float(r.get('wall_time') or 0):.3f}")
        if r["outcome"] in ("failed", "aborted"):
            ET.SubElement(case, "failure", message=f"{r['outcome']}: {r['reason']}")
        elif r["outcome"] == "error":
            ET.SubElement(case, "error", message=str(r["reason"]))
        ET.SubElement(case, "system-out").text = f"run_id={r['run_id']} worker={r.get('worker')}"
    path.parent.mkdir(parents=True, exist_ok=True)
    root = ET.Element("testsuites")
    root.append(suite)
    tree = ET.ElementTree(root)
    ET.indent(tree)
    tree.write(path, encoding="utf-8", xml_declaration=True)


def write_plots(summary: Mapping[str, Any], rows: Sequence[Mapping[str, Any]], folder: Path,
                figure: str | None = None) -> list[Path]:
    """PNG plots with matplotlib (Agg): success rate per cell with its Wilson interval, and the distribution of
    ``figure`` (default: the first aggregated figure) per cell. Returns the files written ([] without matplotlib).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return []
    cells = summary["cells"]
    labels = [c["cell"] for c in cells]
    written = []
    fig, ax = plt.subplots(figsize=(max(4.0, 0.9 * len(cells) + 2), 3.6))
    rates = [100 * (c["success_rate"] or 0.0) for c in cells]
    bars = [error_bars(r, 100 * c["wilson95"][0], 100 * c["wilson95"][1]) for r, c in zip(rates, cells, strict=True)]
    err = [[b[0] for b in bars], [b[1] for b in bars]]
    ax.bar(range(len(cells)), rates, yerr=err, capsize=4, color="#4c72b0")
    ax.set_xticks(range(len(cells)), labels, rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("success rate, % (95 % Wilson)")
    ax.set_ylim(0, 105)
    fig.tight_layout()
    written.append(folder / "success_rate.png")
    fig.savefig(written[-1], dpi=100)
    plt.close(fig)
    name = figure or next(iter(summary["metrics"]), None) or "sim_time"
    data = [[float(v) for r in rows if r["cell"] == c
             for v in [r["figures"].get(name, r.get(name))] if _numeric(v)] for c in labels]
    if any(data):
        fig, ax = plt.subplots(figsize=(max(4.0, 0.9 * len(cells) + 2), 3.6))
        ax.boxplot([d or [math.nan] for d in data])
        ax.set_xticks(range(1, len(cells) + 1), labels, rotation=30, ha="right", fontsize=7)
        ax.set_ylabel(name)
        fig.tight_layout()
        written.append(folder / f"distribution_{name}.png")
        fig.savefig(written[-1], dpi=100)
        plt.close(fig)
    return written
