"""The RunResult: one JSON-serialisable record of a finished run."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
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
    engine: str | None = None
    """The physics engine that ran it (``pybullet``, ``mujoco``): the engines give different outcomes."""
    engine_version: str | None = None
    """That engine package's version."""
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


def early_result(config_path: str, signal_name: str, *, seed: int | None = None) -> tuple[Path, dict[str, Any]]:
    """Where and what to keep for a run stopped by a signal before its config was loaded (imports still going).

    Reads what it can of the TOML with the standard library alone (nothing half-imported is touched): the local
    results folder (``[report.local] dir``, default ``results``), the seed, the behaviour's type, the student and
    project. Returns ``(path of result.json, payload)``; see :func:`write_early_result`.
    """
    import datetime as dt
    import uuid

    raw = _raw_toml(config_path)
    section = lambda *keys: _dig(raw, keys)  # noqa: E731 - a short local lookup
    local = section("report", "local")
    folder = Path(local["dir"]) if isinstance(local, dict) and isinstance(local.get("dir"), str) else Path("results")
    world_seed = section("world", "seed")
    behaviour = section("behaviour", "type")
    result = RunResult(
        run_id=str(uuid.uuid4()), robokit_version=_version(), config=config_path,
        behaviour=behaviour if isinstance(behaviour, str) else None,
        seed=seed if seed is not None else world_seed if isinstance(world_seed, int) else 0,
        outcome="aborted", reason=f"interrupted by {signal_name} during start-up (before the config was loaded)",
        ticks=0, sim_time=0.0, wall_time=0.0,
        started_at=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"), interrupted=True,
    )
    payload = result.to_dict()
    for key in ("student", "project"):
        value = section("report", key)
        if isinstance(value, str):
            payload[key] = value
    return folder / result.run_id / "result.json", payload


def write_early_result(path: Path, payload: dict[str, Any]) -> None:
    """Write ``payload`` to ``path`` atomically (a temporary file beside it, fsync, rename); OSError if it cannot."""
    import json
    import os
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".result-", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(payload, fh, indent=2)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _raw_toml(path: str) -> dict[str, Any]:
    try:
        import tomllib
    except ImportError:  # Python 3.10: no standard TOML reader; keep the defaults
        return {}
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _dig(raw: dict[str, Any], keys: tuple[str, ...]) -> Any:
    value: Any = raw
    for key in keys:
        value = value.get(key) if isinstance(value, dict) else None
    return value


def _version() -> str:
    from robokit import __version__

    return __version__
