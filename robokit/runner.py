"""Running a config end to end: build, run, report. What ``robokit run`` does, usable from code and benchmarks."""

from __future__ import annotations

import contextlib
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
from robokit.config import Config, results_root
from robokit.core.result import OUTCOME_EXIT_CODES, RunResult
from robokit.core.simulation import Simulation
from robokit.errors import ConfigError, Interrupted, PluginError, UserError, plugin_fault
from robokit.plugin_api.plugins import Plugins
from robokit.process.interrupts import StopGuard
from robokit.report.reporting import build_payload, deliver

EXIT_NOT_STORED = 4
"""Exit code when the result could be neither delivered nor stored locally by any reporter."""


@dataclass
class RunOutput:
    """A finished run: its result, the payload delivered, what each reporter did, and the exit code.

    ``interrupted`` is true when Ctrl-C / SIGTERM arrived at any point (start-up, the loop, delivery): the exit
    code is then 130 whatever the outcome. ``error`` is what ended the run with outcome ``error`` (its traceback
    goes to the run folder).
    """

    result: RunResult
    payload: dict[str, Any]
    deliveries: list[tuple[str, Delivery]] = field(default_factory=list)
    interrupted: bool = False
    error: BaseException | None = None

    @property
    def stored(self) -> bool:
        """True if any reporter delivered or stored the result (or there was no reporter to ask)."""
        return not self.deliveries or any(d.delivered or d.stored for _, d in self.deliveries)

    @property
    def exit_code(self) -> int:
        """130 if interrupted; else the run's exit code, or :data:`EXIT_NOT_STORED` when kept nowhere."""
        if self.interrupted or self.result.interrupted:
            return OUTCOME_EXIT_CODES["interrupted"]
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
        except Interrupted:
            raise
        except BaseException as exc:  # noqa: BLE001 - a broken reporter must not cost the result
            reporters.append(_UnbuiltReporter(spec.name, f"reporter {spec.type!r} ({ptype.origin}) failed to "
                                                         f"build: {plugin_fault(exc)}"))
    return reporters


@dataclass
class _UnbuiltReporter:
    """Stands in for a reporter that could not be built: delivers nothing and says why."""

    name: str
    message: str

    def report(self, payload: dict[str, Any]) -> Delivery:
        return Delivery(False, None, self.message)


def error_result(cfg: Config, seed: int, reason: str, *, run_id: str | None = None, outcome: str = "error",
                 interrupted: bool = False) -> RunResult:
    """A RunResult for a run that ended before its first tick (a plugin raised during setup, or Ctrl-C)."""
    return RunResult(
        run_id=run_id or str(uuid.uuid4()), robokit_version=__version__, config=cfg.source,
        behaviour=cfg.behaviour.type if cfg.behaviour else None, seed=seed, outcome=outcome, reason=reason,
        ticks=0, sim_time=0.0, wall_time=0.0,
        started_at=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"), interrupted=interrupted,
    )


def run_config(
    cfg: Config,
    plugins: Plugins,
    *,
    gui: bool | None = None,
    seed: int | None = None,
    max_time: float | None = None,
    max_wall: float | None = None,
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
    Ctrl-C / SIGTERM at any point (see :mod:`robokit.process.interrupts`) stops promptly: during start-up the run ends
    ``aborted`` with no ticks, during the loop at a tick boundary, during delivery at once; the result is kept
    (reporters that send it somewhere slow keep it in their outbox instead) and :attr:`RunOutput.exit_code` is 130.
    """
    run_seed = cfg.world.seed if seed is None else seed
    run_id = str(uuid.uuid4())
    run_dir = _make_run_dir(results_root(cfg) / run_id) if record else None
    error: BaseException | None = None
    with StopGuard.ensure() as guard:
        try:
            sim = Simulation(cfg, plugins, gui=gui, seed=seed, run_id=run_id, run_dir=run_dir,
                             save_frames=save_frames)
            if on_problem is not None:
                try:
                    for problem in sim.preflight():
                        on_problem(problem)
                except BaseException:
                    sim.close()
                    raise
        except UserError:
            if run_dir is not None:  # a config problem found at setup: nothing ran, keep no empty run folder
                with contextlib.suppress(OSError):
                    run_dir.rmdir()
            raise
        except PluginError as exc:
            result, error = error_result(cfg, run_seed, str(exc), run_id=run_id), exc
            if trace is not None:  # the run never started: the trace holds the error alone
                TraceWriter(trace)({"tick": 0, "t": 0.0, "source": "run", "kind": "error", "reason": str(exc)})
        except Interrupted as exc:
            result = error_result(cfg, run_seed, f"interrupted by {exc.reason} during start-up", run_id=run_id,
                                  outcome="aborted", interrupted=True)
        else:
            writer = TraceWriter(trace) if trace is not None else None
            if writer is not None:
                for early in sim.trace:  # written during setup, before the file was listening
                    writer(early)
                sim.trace_listeners.append(writer)
            recorder = None
            try:
                if run_dir is not None:
                    from robokit.record.recorder import Recorder

                    hz = cfg.record.pose_hz if pose_hz is None else pose_hz
                    recorder = Recorder(sim, run_dir, pose_hz=hz)
                    sim.add_monitor(recorder)
                result = sim.run(max_time=max_time, max_wall=max_wall)
                error = sim.error
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
            if writer is not None and writer.failure:
                result.warnings.append(writer.failure)
        payload = build_payload(result, student=cfg.report.student, project=cfg.report.project)
        deliveries = deliver(make_reporters(cfg, plugins), payload, stop=guard) if report else []
        return RunOutput(result, payload, deliveries, interrupted=guard.signalled, error=error)


class TraceWriter:
    """Writes trace records as JSON lines. A write that fails (a full disk, a file that went away) stops the trace
    and is reported as the trace writer's failure, never blamed on the component whose record it was writing."""

    def __init__(self, out: IO[str]) -> None:
        self.out = out
        self.failure: str | None = None

    def __call__(self, record: dict[str, Any]) -> None:
        if self.failure is not None:
            return
        try:
            self.out.write(json.dumps(record, default=str) + "\n")
        except OSError as exc:
            name = getattr(self.out, "name", "the trace file")
            self.failure = (f"trace writer: writing {name} failed at tick {record.get('tick', '?')}: "
                            f"{exc.strerror or exc}; the trace stops there")


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
    for warning in r.warnings:
        lines.append(f"warning: {warning}")
    for name, d in out.deliveries:
        lines.append(f"report[{name}]: {d.message or ('delivered' if d.delivered else 'not delivered')}")
    if not out.stored:
        lines.append("WARNING: the result could not be delivered or stored anywhere")
    return "\n".join(lines)
