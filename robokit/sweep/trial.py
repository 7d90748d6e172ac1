"""Running one trial: config text + overrides + seed -> one row of ``trials.jsonl``.

This is what a worker (a local process or a Ray task) executes. What crosses the process boundary is plain data —
the config's text, its folder, the overrides, the seed, the names of extra plugin modules — never a pybullet object:
the World is built here, inside the worker, and closed before the row goes back.
"""

from __future__ import annotations

import importlib
import os
import socket
import time
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robokit.errors import ConfigError

Before = Callable[[Any, int], None]
"""Called with (simulation, seed) after the world is built, before the run (benchmarks use it to script events)."""
After = Callable[[Any, Any], Mapping[str, Any]]
"""Called with (simulation, RunResult) after the run, before the world closes; returns extra figures."""

_PLUGINS: dict[tuple[str, ...], Any] = {}


@dataclass(frozen=True)
class TrialTask:
    """Everything a worker needs for one trial (all plain, picklable data).

    Attributes:
        key, cell, overrides, seed: The trial (see :class:`robokit.sweep.spec.Trial`).
        run_id: The RunResult's id, derived from the sweep and the key (stable across retries and resumption, so
            a reporter's idempotency key is too).
        config_text: The TOML text of the config.
        source: The config's path as the user gave it (for messages).
        base_dir: The folder relative paths in the config resolve against.
        plugins: Modules imported in the worker and registered as extra plugins.
        before, after: Optional hooks (module-level functions) for benchmarks.
        keep: Whose run record to keep in ``record_dir/<run_id>/`` (``result.json``, ``trace.jsonl``,
            ``poses.npz``): ``"failed"`` (every trial that did not succeed), ``"all"`` or ``"none"``.
        record_dir: Where kept records go (a folder on the machine that runs the trial).
    """

    key: str
    cell: str
    overrides: Mapping[str, Any]
    seed: int
    run_id: str
    config_text: str
    source: str
    base_dir: str
    plugins: tuple[str, ...] = ()
    before: Before | None = field(default=None, compare=False)
    after: After | None = field(default=None, compare=False)
    keep: str = "none"
    record_dir: str | None = None


def trial_run_id(sweep_id: str, key: str) -> str:
    """The run id of a trial: a UUID derived from the sweep's id and the trial key."""
    return str(uuid.uuid5(uuid.UUID(sweep_id), key))


def worker_name() -> str:
    """``host:pid`` of this process (what ``trials.jsonl`` records as the trial's worker)."""
    return f"{socket.gethostname()}:{os.getpid()}"


def plugins_for(modules: tuple[str, ...]) -> Any:
    """The plugin types, loaded once per process (and per set of extra modules)."""
    from robokit.plugin_api.plugins import load_plugins

    if modules not in _PLUGINS:
        _PLUGINS[modules] = load_plugins([importlib.import_module(m) for m in modules])
    return _PLUGINS[modules]


def build_trial_config(config_text: str, source: str, base_dir: str | Path, overrides: Mapping[str, Any],
                       plugins: Any) -> Any:
    """Parse the config text, apply the overrides to the raw TOML tree, validate; a ConfigError names the key."""
    from robokit.config import build_config, set_dotted, tomllib

    try:
        raw = tomllib.loads(config_text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"TOML syntax error: {exc}", file=source) from None
    for dotted, value in overrides.items():
        try:
            set_dotted(raw, dotted, value)
        except ConfigError as exc:
            raise exc.within(file=source) from None
        except (AttributeError, TypeError):
            raise ConfigError(f"cannot set {dotted}: a part of the path is not a table", file=source) from None
    return build_config(raw, plugins, source=source, base_dir=Path(base_dir))


def run_trial(task: TrialTask) -> dict[str, Any]:
    """Run one trial in this process and return its row (the RunResult dict under ``"result"``)."""
    from robokit.core.simulation import Simulation
    from robokit.errors import PluginError, UserError
    from robokit.process.quiet import quiet_stdout
    from robokit.runner import error_result

    t0 = time.perf_counter()
    plugins = plugins_for(task.plugins)
    extra: Mapping[str, Any] = {}
    run_wall = 0.0
    try:
        cfg = build_trial_config(task.config_text, task.source, task.base_dir, task.overrides, plugins)
    except UserError as exc:
        return _row(task, None, extra, t0, error=f"config: {exc}")
    run_dir = Path(task.record_dir) / task.run_id if task.keep in ("failed", "all") and task.record_dir else None
    recorder = None
    try:
        with quiet_stdout():
            sim = Simulation(cfg, plugins, gui=False, seed=task.seed, run_id=task.run_id, run_dir=run_dir)
    except (PluginError, UserError) as exc:
        result = error_result(cfg, task.seed, str(exc))
    else:
        recorder = _recorder(sim, cfg, run_dir)
        try:
            t_run = time.perf_counter()
            if task.before is not None:
                task.before(sim, task.seed)
            result = sim.run()
            run_wall = time.perf_counter() - t_run
            if task.after is not None:
                extra = task.after(sim, result)
            if recorder is not None:
                recorder.finish(result)
        finally:
            sim.close()
    result.run_id = task.run_id
    row = _row(task, result, extra, t0, run_wall)
    if run_dir is not None:
        kept = _keep_record(run_dir, recorder, result, task.keep)
        if kept:
            row["record"] = kept
    return row


def _recorder(sim: Any, cfg: Any, run_dir: Path | None) -> Any:
    """A recorder on the trial's simulation when its record may be kept (None otherwise, or if it cannot start)."""
    if run_dir is None:
        return None
    from robokit.record.recorder import Recorder

    try:
        recorder = Recorder(sim, run_dir, pose_hz=cfg.record.pose_hz)
    except OSError:
        return None
    sim.add_monitor(recorder)
    return recorder


def _keep_record(run_dir: Path, recorder: Any, result: Any, keep: str) -> str | None:
    """Write the trial's ``result.json`` and pose log into ``run_dir``, or remove the folder when ``keep`` is
    ``"failed"`` and the trial succeeded. Returns the folder kept (None if none). A failed write keeps what it can."""
    import json
    import shutil

    if keep == "failed" and result.outcome == "succeeded":
        shutil.rmtree(run_dir, ignore_errors=True)
        return None
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "result.json").write_text(json.dumps(result.to_dict(), indent=2) + "\n", encoding="utf-8")
    except OSError:
        return None
    if recorder is not None:
        recorder.write_poses()
    return str(run_dir)


def _row(task: TrialTask, result: Any, extra: Mapping[str, Any], t0: float, run_wall: float = 0.0,
         error: str = "") -> dict[str, Any]:
    from robokit.core.result import jsonable

    wall = time.perf_counter() - t0
    if result is None:
        return error_row(task, error, wall_time=wall)
    figures = {k: v for k, v in result.result.items() if isinstance(v, (int, float, bool)) or v is None}
    row = {"key": task.key, "cell": task.cell, "overrides": dict(task.overrides), "seed": task.seed,
           "run_id": task.run_id, "outcome": result.outcome, "reason": result.reason,
           "figures": {**figures, **extra}, "sim_time": result.sim_time, "ticks": result.ticks,
           "wall_time": round(wall, 4), "run_wall_time": round(run_wall, 4), "worker": worker_name(),
           "interrupted": result.interrupted, "engine": result.engine, "engine_version": result.engine_version,
           "result": result.to_dict()}
    return jsonable(row)  # type: ignore[no-any-return]


def run_trial_safely(task: TrialTask) -> dict[str, Any]:
    """:func:`run_trial`, with anything it raises turned into an ``error`` row (a worker never dies of a trial)."""
    try:
        return run_trial(task)
    except Exception as exc:  # noqa: BLE001 - one trial's bug must not cost the sweep
        return error_row(task, f"{type(exc).__name__}: {exc}")


def error_row(task: TrialTask, reason: str, worker: str | None = None, wall_time: float = 0.0) -> dict[str, Any]:
    """The row of a trial that produced no RunResult (it raised, timed out, or its worker died)."""
    return {"key": task.key, "cell": task.cell, "overrides": dict(task.overrides), "seed": task.seed,
            "run_id": task.run_id, "outcome": "error", "reason": reason, "figures": {}, "sim_time": None,
            "ticks": None, "wall_time": round(wall_time, 4), "worker": worker or worker_name()}
