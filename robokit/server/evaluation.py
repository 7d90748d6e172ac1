"""Official evaluation: the queue task that runs a submission on its assignment's seeds.

The queue is django-q2 with its ORM broker (a table of the server's database). :func:`create_submission` puts
the task in the same transaction that stores the submission, so a submission is never stored without its task. A
task taken by a worker that is then killed comes back after the broker's ``retry`` seconds;
:func:`evaluate_submission` is idempotent, so the task coming back (or coming twice) never evaluates anything twice:

- each trial's official row has a ``run_id`` derived from the submission and the seed (a unique column): a trial
  already stored is skipped, and a trial can never be stored twice;
- the submission is marked done by a conditional update (``status != done``), once.

Success rate and Wilson interval are :func:`robokit.sweep.summary.summarise`'s, over the trials' rows.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator
from typing import Any

from django.db import IntegrityError, transaction
from django.db.models import Q
from django.utils import timezone

from robokit.server import lease
from robokit.server.assignments import Submission
from robokit.server.fair_queue import claim
from robokit.server.sandbox import Requeue, run_sandboxed
from robokit.server.submitted import scrub

log = logging.getLogger("robokit.server.evaluation")
TASK = lease.TASK
CELL = "official"


def create_submission(admit: Callable[[], None] | None = None, **fields: Any) -> Submission:
    """Store a submission and queue its evaluation in one transaction (never one without the other).

    With ``settings.QUEUE_SYNC`` (tests, ``ROBOKIT_QUEUE_SYNC=1``) the task runs right after, in this process,
    through the same queue library (django-q2's synchronous mode).
    """
    from django.conf import settings
    from django_q.tasks import async_task

    sync = bool(getattr(settings, "QUEUE_SYNC", False))
    with transaction.atomic():
        if admit is not None:  # the per-student limits, counted in this transaction
            admit()
        sub = Submission.objects.create(**fields)
        if not sync:
            async_task(TASK, sub.pk, task_name=f"evaluate submission {sub.pk}")
    if sync:
        async_task(TASK, sub.pk, sync=True, task_name=f"evaluate submission {sub.pk}")
        sub.refresh_from_db()
    return sub


def official_overrides(trial_seconds: float) -> dict[str, Any]:
    """What an official trial sets on top of the submitted config: no wall-clock budget (a submitted
    ``world.max_wall_time`` would make the outcome depend on the machine's load). The trial's budget is its CPU
    time (``trial_seconds``, enforced by :func:`robokit.server.sandbox.official_task`) and the config's simulated
    time."""
    return {"world.max_wall_time": None}


def trial_tasks(sub: Submission, seeds: list[int]) -> list[Any]:
    from robokit.sweep.trial import TrialTask, trial_run_id

    overrides = official_overrides(sub.assignment.trial_seconds)
    modules = tuple(sub.plugin_modules or ())  # the student's plugin package, imported in the sandbox
    return [TrialTask(key=f"seed={s}", cell=CELL, overrides=overrides, seed=int(s),
                      run_id=trial_run_id(str(sub.uuid), f"seed={s}"), config_text=sub.config_text,
                      source=f"submission-{sub.pk}.toml", base_dir=".", plugins=modules) for s in seeds]


def evaluate_submission(submission_id: int) -> str:
    """The queue task: run the trials not stored yet, store each as it ends, then the summary. Idempotent.
    ``submission_id`` is the task's ticket: it evaluates the fairest waiting submission (see :func:`claim`)."""
    sub = Submission.objects.select_related("assignment", "student").filter(pk=claim(submission_id)).first()
    if sub is None or sub.status in (Submission.DONE, Submission.ERROR):
        return "nothing to do"
    me = lease.worker_id()
    if not lease.take(sub.pk, me):
        return "being evaluated by a live worker"
    seeds = [int(s) for s in sub.assignment.seeds]
    stored = set(sub.results.values_list("seed", flat=True))
    todo = trial_tasks(sub, [s for s in seeds if s not in stored])
    beat = lease.Heartbeat(sub.pk, me)
    try:
        for row in run_trials(todo, float(sub.assignment.trial_seconds), dict(sub.plugin_files or {})):
            if beat.lost:
                return "handed over"  # re-queued meanwhile: whoever has it now runs the rest
            store_trial(sub, row)
    except Requeue as exc:  # not the submission's doing: its unfinished trials go back to the queue
        log.warning("evaluation of submission %s re-queued: %s", sub.pk, exc)
        lease.requeue(sub.pk, str(exc), Q(status=Submission.RUNNING, worker=me))
        return "re-queued"
    except Exception as exc:  # noqa: BLE001 - the submission says what went wrong; the queue task ends
        log.exception("evaluation of submission %s failed", sub.pk)
        Submission.objects.filter(pk=sub.pk).exclude(status=Submission.DONE).update(
            status=Submission.ERROR, error=scrub(f"{type(exc).__name__}: {exc}")[:2000])
        return "error"
    finally:
        beat.stop()
    return finish(sub)


def run_trials(tasks: list[Any], trial_seconds: float, files: dict[str, str] | None = None) -> Iterator[dict[str, Any]]:
    """The trials' rows: on the Ray cluster at ``ROBOKIT_RAY_ADDRESS`` through ``robokit sweep``'s Ray backend
    (a trial per Ray task, across the cluster's nodes), otherwise in a local sandbox process. ``files``: a
    student's plugin package, written into the sandbox's scratch folder, or on Ray into a scratch folder that is
    the Ray job's ``working_dir`` (Ray uploads it; each worker runs in its copy, where the modules import)."""
    address = os.environ.get("ROBOKIT_RAY_ADDRESS", "").strip()
    if address:
        return _run_on_ray(address, tasks, trial_seconds, files or {})
    return run_sandboxed(tasks, trial_seconds, files or {})


def _run_on_ray(address: str, tasks: list[Any], trial_seconds: float,
                files: dict[str, str]) -> Iterator[dict[str, Any]]:
    import shutil

    from robokit.server.sandbox import official_task, scratch_folder, trial_wall_limit
    from robokit.sweep.ray_backend import RayBackend

    folder = scratch_folder(files) if files else None
    try:
        backend = RayBackend(address, trial_timeout=trial_wall_limit(trial_seconds),
                             runtime_env={"working_dir": folder} if folder else None)
        for row in backend.run([official_task(t, trial_seconds) for t in tasks]):
            if row.get("outcome") == "error" and row.get("worker") == "ray":  # timed out, or its worker died
                raise Requeue(f"Ray: {row.get('reason')}")
            yield row
    finally:
        if folder:
            shutil.rmtree(folder, ignore_errors=True)


def store_trial(sub: Submission, row: dict[str, Any]) -> None:
    """Store one trial's row as an official result of the submission's student (once: ``run_id`` is unique)."""
    from robokit.server.models import Result, Token

    result = row.get("result") or {}
    figures = {k: v for k, v in (row.get("figures") or {}).items()
               if isinstance(v, (int, float)) and not isinstance(v, bool)}
    figures["success"] = 1 if row["outcome"] == "succeeded" else 0
    token = Token.objects.filter(classroom=sub.assignment.classroom, kind=Token.TEACHER).first()
    payload = {k: scrub(v) if k in ("reason", "error") and isinstance(v, str) else v  # no server paths kept
               for k, v in row.items() if k != "result"}
    payload["result"] = result.get("result") if isinstance(result.get("result"), dict) else {}
    try:
        with transaction.atomic():
            Result.objects.create(
                run_id=row["run_id"], classroom=sub.assignment.classroom, project=sub.assignment.project,
                student=sub.student, student_name=sub.student.name, token=token, verified=True, official=True,
                outcome=row["outcome"], reason=scrub(str(row.get("reason") or ""))[:2000],
                behaviour=str(result.get("behaviour") or "")[:100], config=f"submission-{sub.pk}.toml",
                seed=row["seed"], sim_time=row.get("sim_time"), wall_time=row.get("wall_time"),
                started_at=str(result.get("started_at") or "")[:40], total_time=figures.get("total_time"),
                figures=figures, payload=payload, submission=sub)
    except IntegrityError:
        log.info("trial %s of submission %s was already stored", row["key"], sub.pk)


def finish(sub: Submission) -> str:
    """Summarise the stored trials (the sweep's summary) and mark the submission done, once."""
    from robokit.sweep.summary import summarise

    rows = [{"cell": CELL, "outcome": r.outcome, "figures": r.figures, "overrides": {}, "sim_time": r.sim_time,
             "wall_time": r.wall_time} for r in sub.results.all()]
    if len(rows) < len(sub.assignment.seeds):  # a row could not be stored: say so rather than wait forever
        Submission.objects.filter(pk=sub.pk).exclude(status=Submission.DONE).update(
            status=Submission.ERROR, error=f"{len(rows)} of {len(sub.assignment.seeds)} trials stored")
        return "incomplete"
    summary = summarise(rows, [CELL])
    cell = summary["cells"][0]
    lo, hi = cell["wilson95"]
    changed = Submission.objects.filter(pk=sub.pk).exclude(status=Submission.DONE).update(
        status=Submission.DONE, trials=cell["trials"], succeeded=cell["succeeded"],
        success_rate=cell["success_rate"], wilson_low=lo, wilson_high=hi, summary=summary,
        finished_at=timezone.now())
    return "done" if changed else "already done"
