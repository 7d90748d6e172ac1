"""Running a config end to end: build, run, report. What ``robokit run`` does, usable from code and benchmarks."""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
import shutil
import uuid
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from robokit import __version__
from robokit.components import Delivery
from robokit.config import Config, results_root
from robokit.core.result import RunResult
from robokit.core.simulation import Simulation
from robokit.errors import ConfigError, Interrupted, PluginError, UserError, plugin_fault
from robokit.plugin_api.plugins import Plugins
from robokit.process.interrupts import STARTUP_GRACE, StopGuard, exit_code_for
from robokit.report.reporting import Refused, build_payload, deliver

EXIT_NOT_STORED = 4
"""Exit code when the result could be neither delivered nor stored locally by any reporter."""
EXIT_RECORD_INCOMPLETE = 6
"""Exit code of a run that succeeded and kept its result, but whose record (trace, pose log) could not be written in
full (a full disk, a file-size limit): each failure is a one-line warning naming the file and the reason."""


class RunOutput:
    """A finished run: its result, the payload delivered, what each reporter did, and the exit code.

    ``signal`` names the signal (``SIGINT`` / ``SIGTERM``) received at any point (start-up, the loop, delivery,
    the record's writes): the exit code is then 130 / 143 whatever the outcome. ``error`` is what ended the run with
    outcome ``error`` (its traceback goes to the run folder). ``record_failures`` are the parts of the run record
    that could not be written, one line each (the result itself is kept).
    """

    def __init__(self, result: RunResult, payload: dict[str, Any],
                 deliveries: list[tuple[str, Delivery]] | None = None, interrupted: bool = False,
                 error: BaseException | None = None, signal: str | None = None,
                 record_failures: list[str] | None = None, before_send_error: Exception | None = None) -> None:
        self.result = result
        self.payload = payload
        self.deliveries: list[tuple[str, Delivery]] = [] if deliveries is None else deliveries
        self.interrupted = interrupted
        self.error = error
        self.signal = signal
        self.record_failures: list[str] = [] if record_failures is None else record_failures
        self.before_send_error = before_send_error

    def __repr__(self) -> str:
        return f"RunOutput(outcome={self.result.outcome!r}, exit_code={self.exit_code})"

    @property
    def stored(self) -> bool:
        """True if any reporter delivered or stored the result (or there was no reporter to ask)."""
        return not self.deliveries or any(d.delivered or d.stored for _, d in self.deliveries)

    @property
    def exit_code(self) -> int:
        """130 / 143 if interrupted; else :data:`EXIT_NOT_STORED` when the result is kept nowhere; else the run's
        exit code, or :data:`EXIT_RECORD_INCOMPLETE` for a success whose record is incomplete."""
        if self.interrupted or self.result.interrupted:
            return exit_code_for(self.signal or _signal_of(self.result))
        if not self.stored:
            return EXIT_NOT_STORED
        code = self.result.exit_code
        return EXIT_RECORD_INCOMPLETE if code == 0 and self.record_failures else code


def _signal_of(result: RunResult) -> str | None:
    return "SIGTERM" if "SIGTERM" in result.reason else None


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


class _UnbuiltReporter:
    """Stands in for a reporter that could not be built: delivers nothing and says why."""

    def __init__(self, name: str, message: str) -> None:
        self.name, self.message = name, message

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
        engine=cfg.world.engine,
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
    before_send: Callable[[RunOutput], None] | None = None,
) -> RunOutput:
    """Build the simulation, run it, close it, then hand the payload to every reporter.

    With ``record`` (the default) the run keeps its record in ``<results dir>/<run_id>/`` (see
    :mod:`robokit.record`): the trace with its header, the pose log at ``pose_hz`` (default ``[record] pose_hz``),
    camera frames when ``save_frames``; the local reporter adds ``result.json``.
    The end is ordered so the result survives what follows: the result is delivered (``result.json``, outbox
    entries) first, then the pose log is written, then ``after_run(sim, out)`` is called (``--gui-hold`` uses it),
    then the world closes. A record write that fails is a line in :attr:`RunOutput.record_failures` (exit code
    :data:`EXIT_RECORD_INCOMPLETE` for an otherwise successful run).
    With ``on_problem``, the preflight checks run first and each problem found is handed to it (``robokit run``
    prints them as warnings and runs anyway: the goal check then reports what happened).
    A plugin that raises during setup or the run gives outcome ``error``; whatever result exists is still reported.
    Ctrl-C / SIGTERM at any point (see :mod:`robokit.process.interrupts`) stops promptly: during start-up the run ends
    ``aborted`` with no ticks, during the loop at a tick boundary; after the loop the result is kept as it was
    (reporters that send it somewhere slow keep it in their outbox instead), the pose log is finished or abandoned,
    and :attr:`RunOutput.exit_code` is 130 (SIGINT) or 143 (SIGTERM).
    With ``before_send(out)`` (``robokit run --video``), the pose log is written right after the local delivery and
    ``before_send`` runs then, before the reporters that send the result away: what it adds to the run folder (a
    video) goes with the result (a sender that uploads the record, ``upload_artifacts``, also has the pose log
    written first). A signal there ends ``before_send`` only, and an exception it raises is kept in
    :attr:`RunOutput.before_send_error`: the result is sent (or kept in the outbox) all the same.
    """
    run_id = str(uuid.uuid4())
    run_dir = reserve = None
    try:
        run_dir = _make_run_dir(results_root(cfg) / run_id) if record else None
        reserve = _reserve(run_dir) if run_dir is not None else None
    except KeyboardInterrupt as exc:  # a start-up signal's forced break before this run keeps anything: the caller
        _release(reserve)  # keeps an aborted result (robokit run), and no half-made run folder is left
        if run_dir is not None:
            shutil.rmtree(run_dir, ignore_errors=True)
        exc.robokit_before_run = True  # type: ignore[attr-defined]
        raise
    try:
        return _run_and_keep(cfg, plugins, run_id, run_dir, reserve, gui=gui, seed=seed, max_time=max_time,
                             max_wall=max_wall, trace=trace, report=report, pose_hz=pose_hz, save_frames=save_frames,
                             after_run=after_run, on_problem=on_problem, before_send=before_send)
    finally:
        _release(reserve)


def _run_and_keep(cfg: Config, plugins: Plugins, run_id: str, run_dir: Path | None, reserve: Path | None, *,
                  gui: bool | None, seed: int | None, max_time: float | None, max_wall: float | None,
                  trace: IO[str] | None, report: bool, pose_hz: float | None, save_frames: bool, after_run: Any,
                  on_problem: Callable[[ConfigError], None] | None,
                  before_send: Callable[[RunOutput], None] | None) -> RunOutput:
    """:func:`run_config`'s work, with the run folder made and its space for ``result.json`` reserved."""
    run_seed = cfg.world.seed if seed is None else seed
    error: BaseException | None = None
    sim: Simulation | None = None
    with StopGuard.ensure() as guard:
        try:
            with guard.immediate():  # a signal stops building at once (the run ends aborted, no ticks)
                if guard.signalled:  # it came before this run began (imports, the config): build nothing
                    guard.acted_on()
                    raise Interrupted(guard.signal or "SIGINT")
                sim = _build(cfg, plugins, gui=gui, seed=seed, run_id=run_id, run_dir=run_dir,
                             save_frames=save_frames, on_problem=on_problem)
        except UserError:
            if run_dir is not None:  # a config problem found at setup: nothing ran, keep no empty run folder
                _release(reserve)
                with contextlib.suppress(OSError):
                    run_dir.rmdir()
            raise
        except PluginError as exc:
            result, error = error_result(cfg, run_seed, str(exc), run_id=run_id), exc
            if trace is not None:  # the run never started: the trace holds the error alone
                TraceWriter(trace)({"tick": 0, "t": 0.0, "source": "run", "kind": "error", "reason": str(exc)})
        except Interrupted as exc:
            sim = None
            result = error_result(cfg, run_seed, f"interrupted by {exc.reason} during start-up", run_id=run_id,
                                  outcome="aborted", interrupted=True)
        recorder, failures = None, list[str]()
        if sim is not None:
            result, recorder, failures = _run(sim, cfg, run_dir, trace, guard, pose_hz=pose_hz, max_time=max_time,
                                    max_wall=max_wall)
            error = sim.error
        _release(reserve)  # the space kept for result.json since the run began: the trace could not take it
        out, senders = _keep(cfg, plugins, result, guard, report=report, error=error)
        out.record_failures += failures
        if sim is not None and (before_send is not None or any(getattr(r, "uploads_record", False) for r in senders)):
            _before_send(recorder, out, guard, before_send)
            recorder = None  # its pose log is written
        with guard.immediate():  # a signal keeps the result in the senders' outbox
            out.deliveries += deliver(senders, out.payload, stop=guard)
        if sim is not None:
            _after(sim, recorder, out, guard, after_run)
        out.interrupted, out.signal = guard.signalled or result.interrupted, guard.signal or _signal_of(result)
        return out


RESERVE_FILE = ".result-space"
"""A file in the run folder holding disk space for ``result.json`` while the run writes its trace (see
:func:`_reserve`); deleted just before the result is written."""
RESERVE_SIZES = (65536, 32768, 16384, 8192)
"""Bytes tried, largest first: a result is a few kilobytes; a nearly full disk still gets what it can spare."""


def _reserve(run_dir: Path) -> Path | None:
    """Hold disk space for the run's ``result.json`` before anything else is written: a trace that fills the disk
    during the loop is cut (a record failure, exit 6), and the result is still written. None if no space could be
    held (the result is then written if it fits)."""
    path = run_dir / RESERVE_FILE
    for size in RESERVE_SIZES:
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        except OSError:
            return None
        try:
            os.posix_fallocate(fd, 0, size)
            return path
        except OSError:
            os.ftruncate(fd, 0)
        finally:
            os.close(fd)
    _release(path)
    return None


def _release(reserve: Path | None) -> None:
    if reserve is not None:
        with contextlib.suppress(OSError):
            reserve.unlink(missing_ok=True)


def _build(cfg: Config, plugins: Plugins, *, on_problem: Callable[[ConfigError], None] | None,
           **options: Any) -> Simulation:
    """The Simulation, with its preflight problems handed to ``on_problem`` (closed again if that raises)."""
    sim = Simulation(cfg, plugins, **options)
    if on_problem is not None:
        try:
            for problem in sim.preflight():
                on_problem(problem)
        except BaseException:
            sim.close()
            raise
    return sim


def _run(sim: Simulation, cfg: Config, run_dir: Path | None, trace: IO[str] | None, guard: StopGuard, *,
         pose_hz: float | None, max_time: float | None, max_wall: float | None) -> tuple[RunResult, Any, list[str]]:
    """Attach the trace writer and the recorder, run the loop, end the trace (the pose log is written later).

    Around the loop a signal is only noted (the loop then stops at once); a forced break while the trace ends
    abandons the rest of the trace, never the result.
    """
    writer = TraceWriter(trace) if trace is not None else None
    recorder = None
    failures: list[str] = []
    try:
        with guard.deferred(STARTUP_GRACE):
            if writer is not None:
                for early in sim.trace:  # written during setup, before the file was listening
                    writer(early)
                sim.trace_listeners.append(writer)
            if run_dir is not None:
                from robokit.record.recorder import Recorder

                hz = cfg.record.pose_hz if pose_hz is None else pose_hz
                recorder = Recorder(sim, run_dir, pose_hz=hz)
                sim.add_monitor(recorder)
            result = sim.run(max_time=max_time, max_wall=max_wall)
        try:
            with guard.deferred():
                if recorder is not None:
                    recorder.finish(result)  # the last sample and the trace's end record: quick, before delivery
        except Interrupted as exc:
            recorder.abandon()  # type: ignore[union-attr]
            failures.append(f"run record: the trace's end was abandoned ({exc.reason})")
    except BaseException as exc:
        if run_dir is not None:  # the CLI writes traceback.txt into the run's folder
            exc.robokit_run_dir = run_dir  # type: ignore[attr-defined]
        with contextlib.suppress(Exception):
            if recorder is not None:
                recorder.abandon()
            sim.close()
        raise
    failures = _write_failures(writer, recorder) + failures
    result.warnings += failures  # in result.json too: they happened before it is written
    return result, recorder, failures


def _write_failures(writer: TraceWriter | None, recorder: Any) -> list[str]:
    """The trace files that could not be written in full during the run, one line each."""
    return [f for f in (writer.failure if writer else None, recorder.failure if recorder else None) if f]


def _keep(cfg: Config, plugins: Plugins, result: RunResult, guard: StopGuard, *, report: bool,
          error: BaseException | None) -> tuple[RunOutput, list[Any]]:
    """Keep the result before anything slow: local reporters inside a critical section (a signal waits for
    ``result.json`` to be whole). Returns the output and the reporters that send it away, for the caller to run
    next (a signal there keeps it in their outbox)."""
    payload = build_payload(result, student=cfg.report.student, project=cfg.report.project)
    deliveries: list[tuple[str, Delivery]] = []
    senders: list[Any] = []
    if report:
        reporters = make_reporters(cfg, plugins)
        senders = [r for r in reporters if getattr(r, "sends", False)]
        with guard.deferred(), guard.critical():
            deliveries += deliver([r for r in reporters if r not in senders], payload, stop=guard)
    return RunOutput(result, payload, deliveries, error=error), senders


def _before_send(recorder: Any, out: RunOutput, guard: StopGuard,
                 before_send: Callable[[RunOutput], None] | None) -> None:
    """Write the pose log now (a sender uploads the record, or ``before_send`` needs it), then ``before_send(out)``;
    a signal breaks into it and is told, nothing more."""
    try:
        with guard.deferred():
            if recorder is not None:
                out.record_failures += recorder.write_poses()
        if before_send is not None and not guard.signalled:
            with guard.immediate():
                before_send(out)
    except Exception as exc:  # noqa: BLE001 - told by the caller after the result is sent
        out.before_send_error = exc
    except Interrupted as exc:
        if recorder is not None:
            recorder.abandon()
        out.record_failures.append(f"run record: stopped before the result was sent ({exc.reason})")


def _after(sim: Simulation, recorder: Any, out: RunOutput, guard: StopGuard, after_run: Any) -> None:
    """The slow parts, after the result is kept: the pose log, then ``after_run`` (``--gui-hold``), then closing
    the world. A signal here lets a write finish (or abandons it after the grace): the result stays as kept."""
    try:
        with guard.deferred():
            if recorder is not None:
                out.record_failures += recorder.write_poses()
            if after_run is not None and not guard.signalled:
                after_run(sim, out)
    except Interrupted as exc:
        if recorder is not None:
            recorder.abandon()
        out.record_failures.append(f"run record: the pose log was abandoned ({exc.reason}); the result is kept")
    finally:
        with contextlib.suppress(Interrupted):
            sim.close()


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
    for warning in r.warnings + [f for f in out.record_failures if f not in r.warnings]:
        lines.append(f"warning: {warning}")
    for name, d in out.deliveries:
        if isinstance(d, Refused):  # said once, in the command's own `refused` line (what to change)
            continue
        lines.append(f"report[{name}]: {d.message or ('delivered' if d.delivered else 'not delivered')}")
    if not out.stored:
        lines.append("WARNING: the result could not be delivered or stored anywhere")
    return "\n".join(lines)
