"""The RunResult: one JSON-serialisable record of a finished run."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

SCHEMA = "robokit.run/1"
OUTCOME_EXIT_CODES = {"succeeded": 0, "failed": 1, "aborted": 1, "error": 3, "interrupted": 130}
"""Exit code of ``robokit run`` by outcome (``interrupted`` is an aborted run stopped by Ctrl-C / SIGTERM)."""


@dataclass
class RunResult:
    """What a run produced. ``result`` is the behaviour's own dict; ``outcome`` is one of
    ``succeeded``, ``failed``, ``aborted`` or ``error`` (a plugin raised)."""

    run_id: str
    robokit_version: str
    config: str
    behaviour: str | None
    seed: int
    outcome: str
    reason: str
    ticks: int
    sim_time: float
    wall_time: float
    started_at: str
    result: dict[str, Any] = field(default_factory=dict)
    interrupted: bool = False
    warnings: list[str] = field(default_factory=list)
    """Things the outcome does not show: e.g. a sensor that returned NaN (see :mod:`robokit.core.reading_check`)."""
    schema: str = SCHEMA

    def to_dict(self) -> dict[str, Any]:
        """A plain dict, safe for ``json.dumps`` (NaN/inf become None, numpy values become Python ones)."""
        data = asdict(self)
        data = {"schema": data.pop("schema"), **data}
        return jsonable(data)

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time / self.wall_time if self.wall_time > 0 else math.inf

    @property
    def exit_code(self) -> int:
        """The CLI exit code for this outcome (see :data:`OUTCOME_EXIT_CODES`)."""
        return OUTCOME_EXIT_CODES["interrupted" if self.interrupted else self.outcome]


def jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays, tuples and non-finite floats into plain JSON-safe values."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist"):
        return jsonable(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    return str(value)
