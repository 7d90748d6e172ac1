"""Running a config end to end: build, run, report. What ``robokit run`` does, usable from code and benchmarks."""

from __future__ import annotations

import datetime as dt
import json
import uuid
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from robokit import __version__
from robokit.components import Delivery
from robokit.config import Config
from robokit.errors import ConfigError, PluginError
from robokit.plugins import Plugins
from robokit.reporting import build_payload, deliver
from robokit.result import RunResult
from robokit.simulation import Simulation

EXIT_NOT_STORED = 4
"""Exit code when the result could be neither delivered nor stored locally by any reporter."""


@dataclass
class RunOutput:
    """A finished run: its result, the payload delivered, what each reporter did, and the exit code."""

    result: RunResult
    payload: dict[str, Any]
    deliveries: list[tuple[str, Delivery]] = field(default_factory=list)

    @property
    def stored(self) -> bool:
        """True if any reporter delivered or stored the result (or there was no reporter to ask)."""
        return not self.deliveries or any(d.delivered or d.stored for _, d in self.deliveries)

    @property
    def exit_code(self) -> int:
        """The run's exit code, or :data:`EXIT_NOT_STORED` when the result was kept nowhere."""
        return self.result.exit_code if self.stored else EXIT_NOT_STORED


def make_reporters(cfg: Config, plugins: Plugins) -> list[Any]:
    """Instantiate the reporters a config asks for (``local`` is added unless ``keep_local = false``).

    A reporter whose constructor raises is replaced by one that reports the failure, so the others still run.
    """
    reporters: list[Any] = []
    for spec in cfg.reporters:
        ptype = plugins.get("reporter", spec.type)
        try:
            reporters.append(ptype.cls(spec.name, spec.params))
        except Exception as exc:  # noqa: BLE001 - a broken reporter must not cost the result
            reporters.append(_UnbuiltReporter(spec.name, f"reporter {spec.type!r} ({ptype.origin}) failed to "
                                                         f"build: {type(exc).__name__}: {exc}"))
    return reporters


@dataclass
class _UnbuiltReporter:
    """Stands in for a reporter that could not be built: delivers nothing and says why."""

    name: str
    message: str

    def report(self, payload: dict[str, Any]) -> Delivery:
        return Delivery(False, None, self.message)


def error_result(cfg: Config, seed: int, reason: str) -> RunResult:
    """A RunResult for a run that failed before its first tick (a plugin raised during setup)."""
    return RunResult(
        run_id=str(uuid.uuid4()), robokit_version=__version__, config=cfg.source,
        behaviour=cfg.behaviour.type if cfg.behaviour else None, seed=seed, outcome="error", reason=reason,
        ticks=0, sim_time=0.0, wall_time=0.0,
        started_at=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
    )


def run_config(
    cfg: Config,
    plugins: Plugins,
    *,
    gui: bool | None = None,
    seed: int | None = None,
    max_time: float | None = None,
    trace: IO[str] | None = None,
    report: bool = True,
    record: bool = True,
    pose_hz: float | None = None,
    save_frames: bool = False,
    after_run: Any = None,
    on_problem: Callable[[ConfigError], None] | None = None,
) -> RunOutput:
    """Build the simulation, run it, close it, then hand the payload to every reporter.

    With ``record`` (the default) the run keeps its record in ``<results dir>/<run_id>/`` (see
    :mod:`robokit.record`): the trace with its header, the pose log at ``pose_hz`` (default ``[record] pose_hz``),
    camera frames when ``save_frames``; the local reporter adds ``result.json``. ``after_run(sim)`` is called
    after the last tick, before the world closes (``--gui-hold`` uses it).
    With ``on_problem``, the preflight checks run first and each problem found is handed to it (``robokit run``
    prints them as warnings and runs anyway: the goal check then reports what happened).
    A plugin that raises during setup or the run gives outcome ``error``; whatever result exists is still reported.
    """
    run_seed = cfg.world.seed if seed is None else seed
    run_id = str(uuid.uuid4())
    run_dir = _make_run_dir(results_root(cfg) / run_id) if record else None
    try:
        sim = Simulation(cfg, plugins, gui=gui, seed=seed, run_id=run_id, run_dir=run_dir, save_frames=save_frames)
        if on_problem is not None:
            try:
                for problem in sim.preflight():
                    on_problem(problem)
            except BaseException:
                sim.close()
                raise
    except PluginError as exc:
        result = error_result(cfg, run_seed, str(exc))
        result.run_id = run_id
        if trace is not None:  # the run never started: the trace holds the error alone
            trace.write(json.dumps({"tick": 0, "t": 0.0, "source": "run", "kind": "error", "reason": str(exc)}) + "\n")
    else:
        if trace is not None:
            def write(record: dict[str, Any], out: IO[str] = trace) -> None:
                out.write(json.dumps(record) + "\n")

            for early in sim.trace:  # written during setup, before the file was listening
                write(early)
            sim.trace_listeners.append(write)
        recorder = None
        try:
            if run_dir is not None:
                from robokit.record.recorder import Recorder

                hz = cfg.record.pose_hz if pose_hz is None else pose_hz
                recorder = Recorder(sim, run_dir, pose_hz=hz)
                sim.add_monitor(recorder)
            result = sim.run(max_time=max_time)
            if recorder is not None:
                recorder.close(result)
            if after_run is not None:
                after_run(sim)
        except BaseException as exc:
            if run_dir is not None:  # the CLI writes traceback.txt into the run's folder
                exc.robokit_run_dir = run_dir  # type: ignore[attr-defined]
            raise
        finally:
            if recorder is not None:
                recorder.close()
            sim.close()
    payload = build_payload(result, student=cfg.report.student, project=cfg.report.project)
    deliveries = deliver(make_reporters(cfg, plugins), payload) if report else []
    return RunOutput(result, payload, deliveries)


def _make_run_dir(folder: Path) -> Path | None:
    """Create the run's record folder; on failure warn in one line and run without a record (None)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        warnings.warn(f"no run record: cannot create {folder}: {exc.strerror or exc}", RecordWarning, stacklevel=3)
        return None
    return folder


class RecordWarning(UserWarning):
    """The run record could not be kept (the run itself goes on)."""


def results_root(cfg: Config) -> Path:
    """Where run folders go: the local reporter's ``dir`` (``[report.local] dir``), default ``results``."""
    for spec in cfg.reporters:
        if spec.type == "local" and spec.params is not None and getattr(spec.params, "dir", None):
            return Path(spec.params.dir)
    return Path("results")


def summary(out: RunOutput) -> str:
    """A short human summary: outcome, times, real-time factor, the behaviour's result and where it went."""
    r = out.result
    rtf = f"{r.real_time_factor:.1f}x" if r.wall_time > 0 else "-"
    lines = [
        f"outcome: {r.outcome}" + (f" ({r.reason})" if r.reason else ""),
        f"sim time: {r.sim_time:.2f} s   wall time: {r.wall_time:.2f} s   real-time factor: {rtf}",
    ]
    for key, value in r.result.items():
        if isinstance(value, (dict, list)):
            value = json.dumps(value, default=str)
            value = value if len(value) <= 200 else value[:197] + "..."
        lines.append(f"  {key}: {value}")
    for name, d in out.deliveries:
        lines.append(f"report[{name}]: {d.message or ('delivered' if d.delivered else 'not delivered')}")
    if not out.stored:
        lines.append("WARNING: the result could not be delivered or stored anywhere")
    return "\n".join(lines)
