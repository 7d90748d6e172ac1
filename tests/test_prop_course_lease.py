"""The grading lease over every combination of a submission's state: who may take a submission up
(``lease.take``) and which ones a stopping worker hands back (``lease.hand_back``), judged by the rules of
robokit/server/lease.py's docstrings written here as plain functions: a queued or running submission is taken
unless a live worker (another one, with a fresh heartbeat) has it; a worker hands back only its own running ones."""

from __future__ import annotations

import datetime as dt
import itertools
from typing import Any

import pytest
from course_helpers import Course
from course_work import make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

ME, OTHER = "lab:10/11", "lab:100/11"  # the other's host is ours with a digit more: a prefix is not a match


def may_take(status: str, worker: str, heartbeat_age: float | None, stale: float) -> bool:
    if status not in ("queued", "running"):
        return False
    live_other = worker != ME and heartbeat_age is not None and heartbeat_age < stale
    return status == "queued" or not live_other


def test_take_and_hand_back_over_every_state(course: Course, settings: Any) -> None:
    from django.utils import timezone

    from robokit.server import lease
    from robokit.server.models import Submission

    settings.QUEUE_STALE = 90
    a = make_assignment(course.room, name="lease")
    states = list(itertools.product(["queued", "running", "done"], [ME, OTHER, ""], [None, 10.0, 300.0]))
    now = timezone.now()
    subs = [Submission.objects.create(assignment=a, student=course.kim, config_text="", status=status, worker=worker,
                                      heartbeat=None if age is None else now - dt.timedelta(seconds=age))
            for status, worker, age in states]
    # hand-back first, on the states as made
    held = [s.pk for s, (status, worker, _) in zip(subs, states, strict=True) if status == "running" and worker == ME]
    assert sorted(lease.hand_back("lab:10", "the worker evaluating it was stopped")) == sorted(held)
    for sub, (status, worker, age) in zip(subs, states, strict=True):
        sub.refresh_from_db()
        handed = sub.pk in held
        assert (sub.status, sub.worker) == (("queued", "") if handed else (status, worker)), (status, worker, age)
    # take: on the states as made again (the handed-back ones restored)
    for sub, (status, worker, age) in zip(subs, states, strict=True):
        Submission.objects.filter(pk=sub.pk).update(
            status=status, worker=worker, attempts=0, claim=None,
            heartbeat=None if age is None else timezone.now() - dt.timedelta(seconds=age))
        before = timezone.now()
        taken = lease.take(sub.pk, ME)
        assert taken == may_take(status, worker, age, 90.0), (status, worker, age)
        sub.refresh_from_db()
        if taken:
            assert (sub.status, sub.worker, sub.attempts) == ("running", ME, 1)
            assert sub.heartbeat is not None and sub.heartbeat >= before - dt.timedelta(seconds=1)
        else:
            assert (sub.status, sub.worker, sub.attempts) == (status, worker, 0)


STALE = 90.0
AGES = (None, 10.0, 300.0)  # no time, fresh, stale (QUEUE_STALE = 90 s)


def reaped(status: str, heartbeat_age: float | None, claim: int | None, claimed_age: float | None) -> bool:
    """reap_stale's docstring: running with a heartbeat older than QUEUE_STALE, or claimed by a task that never
    started it (running without a heartbeat, or queued with a claim, claimed longer ago than QUEUE_STALE)."""
    def stale(age: float | None) -> bool:
        return age is not None and age > STALE

    return ((status == "running" and stale(heartbeat_age))
            or (status == "running" and heartbeat_age is None and stale(claimed_age))
            or (status == "queued" and claim is not None and stale(claimed_age)))


def _tasks(before: set[int]) -> list[dict[str, Any]]:
    from django_q.models import OrmQ

    return [o.task for o in OrmQ.objects.order_by("pk") if o.pk not in before]


def test_reap_stale_over_every_state_and_the_tasks_it_queues(course: Course, settings: Any) -> None:
    """Every combination of status, heartbeat, claim, claim time and hand-backs so far: the stale ones (by the rule
    above) are handed back once -- queued again with no worker, heartbeat, claim or claim time, one more hand-back
    and a note saying when and why, a queue task each -- or, after MAX_REQUEUES hand-backs, marked ``error`` with a
    reason; every other submission is left exactly as it was. Then ``top_up`` queues one task per waiting
    submission the queue has no ready task for, named after it."""
    from django.utils import timezone

    from robokit.server import lease
    from robokit.server.models import Submission

    settings.QUEUE_STALE, settings.QUEUE_SYNC = STALE, False
    a = make_assignment(course.room, name="reap")
    now = timezone.now()

    def ago(age: float | None) -> dt.datetime | None:
        return None if age is None else now - dt.timedelta(seconds=age)

    states = list(itertools.product(["queued", "running", "done"], AGES, [None, 7], AGES, [0, lease.MAX_REQUEUES]))
    fields = ("status", "worker", "heartbeat", "claim", "claimed_at", "requeued", "note", "error")
    subs = Submission.objects.bulk_create([
        Submission(assignment=a, student=course.kim, config_text="", status=status, heartbeat=ago(hb), claim=claim,
                   claimed_at=ago(claimed), requeued=n, worker="lab:1/2" if status == "running" else "")
        for status, hb, claim, claimed, n in states])
    before = {s.pk: tuple(getattr(s, f) for f in fields) for s in Submission.objects.filter(assignment=a)}
    expected = [s.pk for s, st in zip(subs, states, strict=True) if reaped(*st[:4])]
    assert sorted(lease.reap_stale(now)) == sorted(expected)
    note = f"re-queued at {timezone.now():%H:%M} UTC: the worker evaluating it stopped"
    notes = {note, f"re-queued at {now:%H:%M} UTC: the worker evaluating it stopped"}  # a minute may turn
    back = []
    for s, (status, hb, claim, claimed, n) in zip(subs, states, strict=True):
        s.refresh_from_db()
        got = {f: getattr(s, f) for f in fields}
        if s.pk in expected:
            assert got["note"] in notes
            got["note"] = note
        if s.pk not in expected:
            assert tuple(got.values()) == before[s.pk], (status, hb, claim, claimed, n)
        elif n >= lease.MAX_REQUEUES:
            assert got == {**got, "status": "error", "worker": "", "heartbeat": None, "note": note,
                           "requeued": n}, (status, hb, claim, claimed, n)
            assert f"handed back to the queue {lease.MAX_REQUEUES} times" in got["error"]
        else:
            assert got == {"status": "queued", "worker": "", "heartbeat": None, "claim": None, "claimed_at": None,
                           "requeued": n + 1, "note": note, "error": ""}, (status, hb, claim, claimed, n)
            back.append(s.pk)
    waiting = sorted(Submission.objects.filter(status="queued", claim__isnull=True).values_list("pk", flat=True))
    tasks = _tasks(set())
    assert sorted(t["name"] for t in tasks[:len(back)]) == sorted(f"evaluate submission {pk} (re-queued)"
                                                                  for pk in back)
    # the hand-backs' tasks are ready in the queue: top_up adds one for each waiting submission beyond them
    assert [t["name"] for t in tasks[len(back):]] == [
        f"evaluate submission {pk} (its task was lost with its worker)" for pk in waiting[len(back):]]
    assert all(t["func"] == lease.TASK and t["args"][0] >= lease.SPARE_TICKETS for t in tasks)
    assert lease.reap_stale(now) == []  # once


@pytest.mark.parametrize("ours_ready,ours_taken,others", [(0, 0, 0), (2, 1, 3), (5, 2, 0), (0, 3, 4)])
def test_top_up_counts_only_this_clusters_ready_tasks(course: Course, settings: Any, ours_ready: int,
                                                      ours_taken: int, others: int) -> None:
    """``top_up`` against the queue's table: tasks of this cluster not yet handed out (lock in the past) count as
    ready, tasks a worker has fetched (lock in the future) and another cluster's tasks do not; claimed and running
    submissions are not waiting. With ``QUEUE_SYNC`` (no workers) it queues nothing."""
    from django.utils import timezone
    from django_q.models import OrmQ

    from robokit.server import lease
    from robokit.server.models import Submission

    settings.QUEUE_SYNC = False
    a = make_assignment(course.room, name="top up")
    subs = Submission.objects.bulk_create([
        Submission(assignment=a, student=course.kim, config_text="", status=status, claim=claim)
        for status, claim in [("queued", None)] * 4 + [("queued", 9), ("running", None), ("done", None)]])
    waiting = [s.pk for s in subs[:4]]
    now = timezone.now()
    name = settings.Q_CLUSTER["name"]
    for key, lock, n in ((name, now - dt.timedelta(seconds=5), ours_ready), (name, now + dt.timedelta(hours=1),
                                                                              ours_taken),
                         ("another cluster", now - dt.timedelta(seconds=5), others)):
        OrmQ.objects.bulk_create([OrmQ(key=key, payload="x", lock=lock) for _ in range(n)])
    seen = set(OrmQ.objects.values_list("pk", flat=True))
    settings.QUEUE_SYNC = True
    assert lease.top_up() == 0 and OrmQ.objects.count() == len(seen)
    settings.QUEUE_SYNC = False
    missing = waiting[ours_ready:]
    assert lease.top_up() == len(missing)
    assert [t["name"] for t in _tasks(seen)] == [f"evaluate submission {pk} (its task was lost with its worker)"
                                                 for pk in missing]


def test_a_hand_back_says_why_and_a_worker_without_a_queue_queues_no_task(course: Course, settings: Any) -> None:
    """The note of a submission handed back names the reason given; with ``QUEUE_SYNC`` a requeue changes the
    submission and queues no task (there is no worker to take it)."""
    from django.db.models import Q
    from django_q.models import OrmQ

    from robokit.server import lease
    from robokit.server.models import Submission

    a = make_assignment(course.room, name="why")
    sub = Submission.objects.create(assignment=a, student=course.kim, config_text="", status="running",
                                    worker="lab:10/4")
    settings.QUEUE_SYNC = False
    assert lease.hand_back("lab:10", "the worker was stopped (SIGTERM)") == [sub.pk]
    sub.refresh_from_db()
    assert sub.note.endswith(" UTC: the worker was stopped (SIGTERM)") and OrmQ.objects.count() == 1
    assert not lease.requeue(sub.pk, "again", Q(status="running"))  # not running now: nothing, no task
    assert OrmQ.objects.count() == 1
    settings.QUEUE_SYNC = True
    Submission.objects.filter(pk=sub.pk).update(status="running", worker="lab:10/4")
    assert lease.requeue(sub.pk, "again", Q(status="running")) and OrmQ.objects.count() == 1
