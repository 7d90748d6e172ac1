"""The sweep engine: validate every cell, skip finished trials, run the rest on a backend, record, summarise.

Files in the output folder ``DIR``:

- ``sweep.json``: the sweep's id and identity (config text digest, fixed overrides, the digest of every file the
  config refers to, robokit's, pybullet's and the plugin distributions' versions; see
  :mod:`robokit.sweep.identity`); resuming with any of them changed is refused, naming what changed.
- ``trials.jsonl``: one line per finished trial, appended and flushed as each trial ends (a crash or Ctrl-C loses
  nothing); re-running the same sweep skips every key already there.
- ``summary.json``, ``summary.md``: per cell, trials, success rate with its 95 % Wilson interval, median and p95.
- ``success_rate.png``, ``distribution_<figure>.png`` when matplotlib is installed (``robokit[video]``).
"""

from __future__ import annotations

import datetime as dt
import json
import os
import sys
import uuid
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from robokit.errors import UserError
from robokit.sweep.progress import Progress
from robokit.sweep.spec import SweepSpec, Trial
from robokit.sweep.summary import failed_trials, summarise, to_markdown, write_junit, write_plots
from robokit.sweep.trial import After, Before, TrialTask, build_trial_config, plugins_for, trial_run_id

Backend = Callable[[Sequence[TrialTask]], Iterator[dict[str, Any]]]


@dataclass
class SweepRun:
    """What a sweep invocation did.

    Attributes:
        rows: Every finished trial of the sweep (earlier invocations included), in the sweep's trial order.
        summary: :func:`robokit.sweep.summary.summarise` of ``rows``.
        ran: Trials run by this invocation.
        skipped: Trials already in ``trials.jsonl``.
        remaining: Trials still to run (non-zero after ``max_trials`` or an interrupt).
        interrupted: Ctrl-C / SIGTERM stopped it.
        files: What was written (summary, plots, JUnit).
        out: The output folder used (``--new-out`` may have chosen a new one).
    """

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    ran: int = 0
    skipped: int = 0
    remaining: int = 0
    interrupted: bool = False
    files: list[Path] = field(default_factory=list)
    out: Path | None = None

    @property
    def all_succeeded(self) -> bool:
        """Every trial ran and succeeded."""
        return self.remaining == 0 and all(r["outcome"] == "succeeded" for r in self.rows)


@dataclass
class SweepOptions:
    """How to run a sweep (where, on what, with which limits)."""

    out: Path | None = None
    backend: str = "local"
    workers: int | None = None
    address: str | None = None
    trial_timeout: float | None = None
    max_trials: int | None = None
    max_tasks_per_child: int = 100
    report_url: str | None = None
    student: str | None = None
    project: str | None = None
    junit: Path | None = None
    plot: str | None = None
    new_out: bool = False
    keep: str = "failed"
    progress: IO[str] | None = None
    before: Before | None = None
    after: After | None = None


def run_sweep(spec: SweepSpec, options: SweepOptions | None = None) -> SweepRun:
    """Run a sweep: validate every cell first (a bad key or value is one UserError before any trial runs), skip
    the trials already recorded in ``options.out``, run the rest, and write the summary.
    """
    opts = options or SweepOptions()
    text, plugins = _prepare(spec)
    trials = spec.trials()
    reporting = _reporting(spec, text, plugins, opts)
    sweep_id, done, opts.out = _open_out(spec, full_identity(spec, text, plugins), opts.out, opts.new_out)
    todo = [t for t in trials if t.key not in done]
    if opts.max_trials is not None:
        todo = todo[: max(0, opts.max_trials)]
    tasks = [_task(spec, text, t, sweep_id, opts) for t in todo]
    skipped = sum(t.key in done for t in trials)
    failed_before = sum(done[t.key]["outcome"] != "succeeded" for t in trials if t.key in done)
    progress = Progress(len(trials), skipped, failed_before, opts.progress)
    run = SweepRun([], {}, skipped=skipped)
    try:
        for row in _backend(spec, opts)(tasks):
            if row.pop("interrupted", False):  # the worker saw the Ctrl-C: not a finished trial
                continue
            result = row.pop("result", None)
            if reporting is not None:
                row["delivered"] = _deliver(reporting, row, result)
            _append(opts.out, row)
            done[row["key"]] = row
            run.ran += 1
            progress.update(row)
    except KeyboardInterrupt:
        run.interrupted = True
    finally:
        progress.close()
    order = {t.key: i for i, t in enumerate(trials)}
    run.rows = sorted((r for k, r in done.items() if k in order), key=lambda r: order[r["key"]])
    run.remaining = len(trials) - len(run.rows)
    run.summary = summarise(run.rows, [cell for cell, _ in spec.cells()], spec.metrics)
    run.summary["failed_trials"] = failed_trials(run.rows, str(spec.config))
    run.out = opts.out
    run.files = _write_outputs(run, opts)
    return run


def _prepare(spec: SweepSpec) -> tuple[str, Any]:
    """Read the config, load the plugins, validate every cell's overrides (before any trial runs)."""
    try:
        text = spec.config.read_text(encoding="utf-8")
    except OSError as exc:
        raise UserError(f"{spec.config}: cannot read the config: {exc.strerror}") from None
    try:
        plugins = plugins_for(spec.plugins)
    except ImportError as exc:
        raise UserError(f"--plugin: cannot import {exc.name or exc}: {exc}") from None
    for _cell, overrides in spec.cells():
        build_trial_config(text, str(spec.config), spec.config.resolve().parent, overrides, plugins)
    return text, plugins


def _task(spec: SweepSpec, text: str, trial: Trial, sweep_id: str, opts: SweepOptions) -> TrialTask:
    return TrialTask(trial.key, trial.cell, dict(trial.overrides), trial.seed, trial_run_id(sweep_id, trial.key),
                     text, str(spec.config), str(spec.config.resolve().parent), spec.plugins, opts.before,
                     opts.after, keep=opts.keep if opts.out is not None else "none",
                     record_dir=str((opts.out / "runs").resolve()) if opts.out is not None else None)


def _backend(spec: SweepSpec, opts: SweepOptions) -> Backend:
    if opts.backend == "local":
        from robokit.sweep.local import LocalPool

        return LocalPool(opts.workers, trial_timeout=opts.trial_timeout, plugins=spec.plugins,
                         max_tasks_per_child=opts.max_tasks_per_child).run
    if opts.backend == "ray":
        from robokit.sweep.ray_backend import RayBackend

        return RayBackend(opts.address, trial_timeout=opts.trial_timeout).run
    raise UserError(f"--backend: expected 'local' or 'ray', got {opts.backend!r}")


def full_identity(spec: SweepSpec, text: str, plugins: Any) -> dict[str, Any]:
    """:meth:`SweepSpec.identity` plus the digests of every file the config refers to, the sweep file's digest and
    the versions of robokit, pybullet and the plugin distributions (see :mod:`robokit.sweep.identity`)."""
    from robokit.config import tomllib
    from robokit.sweep.identity import file_digests, sha256_file, versions

    raw = tomllib.loads(text)
    values = [*spec.fixed.values(), *(v for vs in spec.grid.values() for v in vs)]
    identity = {**spec.identity(text), "files": file_digests(raw, spec.config.resolve().parent, values),
                "versions": versions(plugins)}
    if spec.sweep_file is not None:
        identity["sweep_file"] = {"path": str(spec.sweep_file), "sha256": sha256_file(spec.sweep_file)}
    return identity


def _open_out(spec: SweepSpec, identity: dict[str, Any], out: Path | None,
              new_out: bool = False) -> tuple[str, dict[str, dict[str, Any]], Path | None]:
    """Create or reopen the output folder; return the sweep id, the rows already recorded (by key) and the folder.

    A folder whose ``sweep.json`` differs from ``identity`` is refused in one line naming what changed; with
    ``new_out`` a new folder beside it (``<out>-2``, ``-3`` ...) is used instead.
    """
    from robokit.sweep.identity import what_changed

    if out is None:
        return str(uuid.uuid4()), {}, None
    out.mkdir(parents=True, exist_ok=True)
    meta_path = out / "sweep.json"
    if meta_path.exists():
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
        changed = what_changed(meta, identity)
        if changed and new_out:
            return _open_out(spec, identity, _next_free(out), new_out)
        if changed:
            raise UserError(f"{out}: cannot resume this sweep: {'; '.join(changed)} since it began (config "
                            f"{meta.get('config')}); add --new-out to start a new folder beside it, or delete it")
        sweep_id = str(meta["sweep_id"])
    else:
        sweep_id = str(uuid.uuid4())
        meta = {"schema": "robokit.sweep/1", "sweep_id": sweep_id, "config": str(spec.config), **identity,
                "created_at": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")}
        meta_path.write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
    return sweep_id, read_trials(out / "trials.jsonl"), out


def _next_free(out: Path) -> Path:
    """``<out>-2``, ``-3`` ...: the first that does not exist yet."""
    n = 2
    while out.with_name(f"{out.name}-{n}").exists():
        n += 1
    return out.with_name(f"{out.name}-{n}")


def read_trials(path: Path) -> dict[str, dict[str, Any]]:
    """The rows of a ``trials.jsonl`` by key. A torn last line (the process died mid-write) is cut off."""
    if not path.exists():
        return {}
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        data = data[: data.rfind(b"\n") + 1]
        with open(path, "r+b") as fh:
            fh.truncate(len(data))
    rows = {}
    for line in data.decode("utf-8").splitlines():
        if line.strip():
            row = json.loads(line)
            rows[row["key"]] = row
    return rows


def _append(out: Path | None, row: Mapping[str, Any]) -> None:
    if out is None:
        return
    with open(out / "trials.jsonl", "a", encoding="utf-8") as fh:
        fh.write(json.dumps(row, separators=(",", ":")) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def _reporting(spec: SweepSpec, text: str, plugins: Any, opts: SweepOptions) -> tuple[Any, list[Any]] | None:
    """The config (with the report options) and its reporters other than ``local`` (``trials.jsonl`` is the
    sweep's local record); None when there is nothing to report to."""
    from robokit.runner import make_reporters

    extra: dict[str, Any] = {"report.keep_local": False}
    for key, value in (("report.http.url", opts.report_url), ("report.student", opts.student),
                       ("report.project", opts.project)):
        if value is not None:
            extra[key] = value
    cfg = build_trial_config(text, str(spec.config), spec.config.resolve().parent, {**spec.fixed, **extra},
                             plugins)
    reporters = [r for r, s in zip(make_reporters(cfg, plugins), cfg.reporters, strict=True) if s.type != "local"]
    return (cfg, reporters) if reporters else None


def _deliver(reporting: tuple[Any, list[Any]], row: dict[str, Any], result: dict[str, Any] | None) -> bool:
    """Hand one trial's RunResult to the reporters (the http one keeps it in its outbox until a 2xx).

    The run id is derived from the sweep and the trial key, so a trial re-run after a crash between delivery and
    recording is sent with the same ``Idempotency-Key``.
    """
    from robokit.core.result import RunResult
    from robokit.report.reporting import build_payload, deliver
    from robokit.runner import error_result

    cfg, reporters = reporting
    if result is None:
        run_result = error_result(cfg, row["seed"], row["reason"])
        run_result.run_id = row["run_id"]
    else:
        run_result = RunResult(**result)
    payload = build_payload(run_result, student=cfg.report.student, project=cfg.report.project)
    payload["sweep"] = {"cell": row["cell"], "key": row["key"], "overrides": row["overrides"]}
    return all(d.delivered or d.stored for _, d in deliver(reporters, payload))


class SweepWarning(UserWarning):
    """Part of a sweep's outputs could not be made (a plot); the rest is written."""


def _write_outputs(run: SweepRun, opts: SweepOptions) -> list[Path]:
    """The summary (JSON, Markdown) and the JUnit file first; then the plots, whose failure is only a warning."""
    files: list[Path] = []
    if opts.out is not None:
        (opts.out / "summary.json").write_text(json.dumps(run.summary, indent=2) + "\n", encoding="utf-8")
        (opts.out / "summary.md").write_text(to_markdown(run.summary), encoding="utf-8")
        files += [opts.out / "summary.json", opts.out / "summary.md"]
    if opts.junit is not None:
        write_junit(run.rows, opts.junit)
        files.append(opts.junit)
    if opts.out is not None:
        try:
            files += write_plots(run.summary, run.rows, opts.out, opts.plot)
        except Exception as exc:  # noqa: BLE001 - a plot is never worth the summary
            import warnings

            from robokit.process.crash import describe

            warnings.warn(f"sweep: the plots in {opts.out} could not be drawn: {describe(exc)}; the summary, table "
                          "and JUnit file are written", SweepWarning, stacklevel=2)
    return files


def default_progress_stream() -> IO[str]:
    """Where progress goes: stdout (a live bar on a terminal, one line every few trials otherwise)."""
    return sys.stdout
