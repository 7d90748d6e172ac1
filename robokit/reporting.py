"""Turning a RunResult into the payload reporters deliver, and running the reporters.

The payload is the RunResult dict with the course server's fields (``student``, ``project``, ``red_sorted``,
``blue_sorted``, ``failures``, ``total_time``) copied to the top level when present, for compatibility with
lesson 08's ``POST /api/robotics/result/``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from robokit.components import Delivery
from robokit.result import RunResult

COURSE_FIELDS = ("red_sorted", "blue_sorted", "failures", "total_time")


def build_payload(result: RunResult, *, student: str | None = None, project: str | None = None) -> dict[str, Any]:
    """The RunResult as a dict plus the course's top-level fields."""
    payload = result.to_dict()
    if student is not None:
        payload["student"] = student
    if project is not None:
        payload["project"] = project
    for key in COURSE_FIELDS:
        if key in payload["result"]:
            payload[key] = payload["result"][key]
    return payload


def deliver(reporters: Iterable[Any], payload: dict[str, Any]) -> list[tuple[str, Delivery]]:
    """Run every reporter; a reporter that raises counts as a failed, unstored delivery (never propagates)."""
    out = []
    for reporter in reporters:
        try:
            delivery = reporter.report(payload)
        except Exception as exc:  # noqa: BLE001 - reporting never changes the run's outcome
            delivery = Delivery(False, None, f"{reporter.name}: {type(exc).__name__}: {exc}")
        out.append((reporter.name, delivery))
    return out
