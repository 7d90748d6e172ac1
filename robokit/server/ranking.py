"""Ranking runs: each student's best run by the project's figures, and the table's columns."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

COURSE_ORDER = ("sorted_total", "red_sorted", "blue_sorted", "failures", "total_time")
MAX_COLUMNS = 8


def sort_key(result: Any, keys: list[tuple[str, bool]]) -> tuple[Any, ...]:
    """Smaller is better: a successful (or outcome-less, as lesson 08 posts) run first, then each figure in
    ``keys`` (``(name, higher_is_better)``; a missing figure ranks last), then the earlier run."""
    parts: list[Any] = [0 if result.outcome in ("", "succeeded") else 1]
    for name, higher in keys:
        value = result.figures.get(name)
        parts.append((1, 0) if value is None else (0, -value if higher else value))
    parts.append(result.received_at)
    parts.append(result.pk)
    return tuple(parts)


def best_per_student(results: Iterable[Any], keys: list[tuple[str, bool]]) -> list[Any]:
    """Each student's best run, best first. A student is their account (verified) or their posted name."""
    best: dict[tuple[str, Any], Any] = {}
    for r in results:
        who = ("id", r.student_id) if r.student_id is not None else ("name", r.student_name)
        if who not in best or sort_key(r, keys) < sort_key(best[who], keys):
            best[who] = r
    return sorted(best.values(), key=lambda r: sort_key(r, keys))


def columns(ranking: list[tuple[str, bool]], seen: Iterable[dict[str, Any]]) -> list[str]:
    """The figures shown: the ranking's, then the course fields, then the rest seen, at most MAX_COLUMNS."""
    names: list[str] = [name for name, _ in ranking]
    found: set[str] = set()
    for figs in seen:
        found.update(figs)
    names += [n for n in COURSE_ORDER if n in found and n not in names]
    names += sorted(n for n in found if n not in names)
    return names[:MAX_COLUMNS]
