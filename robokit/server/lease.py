"""Who is evaluating a submission, and handing it back to the queue when that worker is gone.

A worker that takes a submission up writes its name (``worker``) and the time (``heartbeat``) on it, and touches
the heartbeat every ``settings.QUEUE_HEARTBEAT`` seconds while the trials run (:class:`Heartbeat`). A submission
whose heartbeat is older than ``settings.QUEUE_STALE`` seconds belongs to a worker that died: :func:`reap_stale`
(run by every ``robokit worker`` when it starts and then every ``QUEUE_STALE / 3`` seconds) hands it back to the
queue with a new task, once — the hand-back is a conditional update on the stale state, so of two reapers one
wins. The student's pages show the note it leaves (``re-queued at 14:02 UTC: ...``).

The queue library's own redelivery (django-q2's ORM broker hands a task out again after its ``retry`` seconds) is
the slow second net: a task that comes back finds its submission done, or evaluated by a live worker, and ends.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
from datetime import datetime, timedelta
from typing import Any

from django.conf import settings
from django.db import DatabaseError, close_old_connections, connection, transaction
from django.db.models import F, Q
from django.utils import timezone

from robokit.server.assignments import Submission

log = logging.getLogger("robokit.server.lease")
WORKER_ENV = "ROBOKIT_WORKER_ID"
SPARE_TICKETS = 10**15
MAX_REQUEUES = 5
"""Hand-backs after which a submission is marked ``error`` instead (a teacher can have it evaluated again)."""
TASK = "robokit.server.evaluation.evaluate_submission"
"""The queue's task that evaluates a submission, by its dotted path (django-q imports it by name)."""


def spare_ticket() -> int:
    """A ticket for a task queued here (:mod:`robokit.server.fair_queue`): above every submission's id, so never
    shared with a task that may still come back; random, so two workers never make the same one."""
    import secrets

    return SPARE_TICKETS + secrets.randbits(48)


def worker_id() -> str:
    """``host:pid/pid`` of this queue process: the ``robokit worker`` it belongs to, then its own process id."""
    return f"{os.environ.get(WORKER_ENV) or socket.gethostname()}/{os.getpid()}"


def stale_after() -> timedelta:
    return timedelta(seconds=float(settings.QUEUE_STALE))


def take(pk: int, worker: str) -> bool:
    """Mark the submission as evaluated by ``worker`` now, unless a live worker has it (a fresh heartbeat)."""
    now = timezone.now()
    free = Q(status=Submission.QUEUED) | Q(heartbeat__isnull=True) | Q(heartbeat__lt=now - stale_after()) | Q(
        worker=worker)
    return bool(Submission.objects.filter(pk=pk, status__in=(Submission.QUEUED, Submission.RUNNING)).filter(
        free).update(status=Submission.RUNNING, attempts=F("attempts") + 1, heartbeat=now, worker=worker))


class Heartbeat:
    """Touches the submission's heartbeat every ``settings.QUEUE_HEARTBEAT`` seconds from a thread of its own;
    :attr:`lost` when the submission is no longer this worker's (handed back meanwhile). Inert without workers
    (``settings.QUEUE_SYNC``: nothing reaps then)."""

    def __init__(self, pk: int, worker: str) -> None:
        self.pk, self.worker, self.lost = pk, worker, False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if not getattr(settings, "QUEUE_SYNC", False):
            self._thread = threading.Thread(target=self._run, name=f"heartbeat {pk}", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.wait(float(settings.QUEUE_HEARTBEAT)):
                try:
                    touched = Submission.objects.filter(pk=self.pk, status=Submission.RUNNING,
                                                        worker=self.worker).update(heartbeat=timezone.now())
                except DatabaseError as exc:  # the database is away for a moment: try again next time
                    log.warning("heartbeat of submission %s: %s", self.pk, exc)
                    close_old_connections()
                    continue
                if not touched:
                    self.lost = True
                    return
        finally:
            connection.close()  # this thread's own connection

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()


def requeue(pk: int, why: str, only_if: Q) -> bool:
    """Hand the submission back to the queue (a new task), if it still matches ``only_if``; after
    :data:`MAX_REQUEUES` hand-backs it is marked ``error`` instead. Returns whether this call changed it."""
    from django_q.tasks import async_task

    now = timezone.now()
    note = f"re-queued at {now:%H:%M} UTC: {why}"[:300]
    with transaction.atomic():
        mine = Submission.objects.filter(pk=pk).filter(only_if)
        if mine.filter(requeued__gte=MAX_REQUEUES).update(
                status=Submission.ERROR, heartbeat=None, worker="", note=note,
                error=f"not evaluated: handed back to the queue {MAX_REQUEUES} times (last: {why}); a teacher can "
                      f"have it evaluated again"[:2000]):
            return True
        changed = mine.update(status=Submission.QUEUED, claim=None, claimed_at=None, heartbeat=None, worker="",
                              requeued=F("requeued") + 1, note=note)
        if changed and not getattr(settings, "QUEUE_SYNC", False):
            async_task(TASK, spare_ticket(), task_name=f"evaluate submission {pk} (re-queued)")
    if changed:
        log.warning("submission %s re-queued: %s", pk, why)
    return bool(changed)


def reap_stale(now: datetime | None = None) -> list[int]:
    """Hand back every submission whose worker stopped: running with a heartbeat older than
    ``settings.QUEUE_STALE``, or claimed by a queue task that never started it. Returns their ids."""
    cut = (now or timezone.now()) - stale_after()
    stale = Submission.objects.filter(
        Q(status=Submission.RUNNING, heartbeat__lt=cut)
        | Q(status=Submission.RUNNING, heartbeat__isnull=True, claimed_at__lt=cut)
        | Q(status=Submission.QUEUED, claim__isnull=False, claimed_at__lt=cut)).values_list(
        "pk", "status", "heartbeat", "claim")
    done = []
    for pk, status, heartbeat, ticket in list(stale):
        same: dict[str, Any] = {"status": status, "claim": ticket}
        same.update({"heartbeat": heartbeat} if heartbeat is not None else {"heartbeat__isnull": True})
        if requeue(pk, "the worker evaluating it stopped", Q(**same)):
            done.append(pk)
    if done:
        top_up()
    return done


def top_up() -> int:
    """Queue a task for every waiting submission beyond the tasks the queue can hand out now; returns how many.

    A worker that dies takes with it the tasks its cluster had fetched ahead (taken from the queue's table, not yet
    started): they would come back only after the broker's ``retry``. Tasks are tickets for the fairest waiting
    submission, so a spare one costs nothing (it finds nothing to do); a missing one leaves a submission waiting. Run
    when a worker starts and whenever a stopped worker's submission is handed back."""
    from django_q.models import OrmQ
    from django_q.tasks import async_task

    if getattr(settings, "QUEUE_SYNC", False):
        return 0
    waiting = list(Submission.objects.filter(status=Submission.QUEUED, claim__isnull=True).order_by("pk")
                   .values_list("pk", flat=True))
    ready = OrmQ.objects.filter(key=settings.Q_CLUSTER["name"], lock__lt=timezone.now()).count()
    missing = waiting[ready:]
    for pk in missing:
        async_task(TASK, spare_ticket(), task_name=f"evaluate submission {pk} (its task was lost with its worker)")
    if missing:
        log.warning("queued %d task(s) lost with a stopped worker", len(missing))
    return len(missing)


def hand_back(worker_prefix: str, why: str) -> list[int]:
    """Hand back every submission a queue process of this ``robokit worker`` (``worker_prefix``) is evaluating:
    the worker is stopping. Returns their ids."""
    held = Submission.objects.filter(status=Submission.RUNNING, worker__startswith=f"{worker_prefix}/")
    return [pk for pk, worker in list(held.values_list("pk", "worker"))
            if requeue(pk, why, Q(status=Submission.RUNNING, worker=worker))]
