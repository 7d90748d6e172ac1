"""A stopped worker's submission goes back to the queue once, and nothing of a live one's does: the lease's rules on
the real database (the hand-back's conditional update, the tasks queued again), and the scratch folders a stopped
evaluation leaves, told apart from a running one's."""

from __future__ import annotations

import datetime as dt
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from course_helpers import Course
from course_work import make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
NOW = dt.datetime(2026, 12, 4, 9, 0, tzinfo=dt.timezone.utc)


def submission(course: Course, **fields: Any) -> Any:
    from robokit.server.models import Submission

    a = make_assignment(course.room, name=f"과제 {Submission.objects.count()}")
    return Submission.objects.create(assignment=a, student=course.kim, config_text="", **fields)


def test_a_stale_heartbeat_is_handed_back_once_and_a_fresh_one_never(course: Course, settings: Any) -> None:
    from django_q.models import OrmQ

    from robokit.server import lease

    settings.QUEUE_STALE = 90
    stale = submission(course, status="running", worker="lab:1/2", heartbeat=NOW - dt.timedelta(seconds=91))
    fresh = submission(course, status="running", worker="lab:1/3", heartbeat=NOW - dt.timedelta(seconds=89))
    never_started = submission(course, status="queued", claim=7, claimed_at=NOW - dt.timedelta(seconds=120))
    waiting = submission(course, status="queued")
    assert sorted(lease.reap_stale(NOW)) == sorted([stale.pk, never_started.pk])
    assert lease.reap_stale(NOW) == []  # once: the hand-back changed what made it stale
    for sub in (stale, fresh, never_started, waiting):
        sub.refresh_from_db()
    assert (stale.status, stale.requeued, stale.worker, stale.heartbeat, stale.claim) == ("queued", 1, "", None, None)
    assert stale.note.endswith(" UTC: the worker evaluating it stopped") and stale.note.startswith("re-queued at ")
    assert (never_started.status, never_started.claim, never_started.requeued) == ("queued", None, 1)
    assert (fresh.status, fresh.requeued, fresh.note) == ("running", 0, "")
    assert (waiting.requeued, waiting.note) == (0, "")
    # a task each for the two handed back, then one more per waiting submission the queue had no task for
    tickets = [o.task["args"][0] for o in OrmQ.objects.all()]
    assert len(tickets) == 3 and len(set(tickets)) == 3 and all(t >= lease.SPARE_TICKETS for t in tickets)


def test_after_max_requeues_a_submission_is_an_error_a_teacher_can_rerun(course: Course, settings: Any) -> None:
    from django.db.models import Q

    from robokit.server import lease

    sub = submission(course, status="running", worker="lab:1/2", requeued=lease.MAX_REQUEUES)
    assert lease.requeue(sub.pk, "the worker evaluating it stopped", Q(status="running"))
    sub.refresh_from_db()
    assert sub.status == "error" and sub.error.startswith(f"not evaluated: handed back to the queue "
                                                          f"{lease.MAX_REQUEUES} times")


def test_a_worker_takes_a_submission_only_from_a_dead_or_no_worker(course: Course, settings: Any) -> None:
    from django.utils import timezone

    from robokit.server import lease

    settings.QUEUE_STALE = 90
    live = submission(course, status="running", worker="lab:1/2", heartbeat=timezone.now())
    dead = submission(course, status="running", worker="lab:1/3",
                      heartbeat=timezone.now() - dt.timedelta(seconds=300))
    done = submission(course, status="done")
    assert not lease.take(live.pk, "lab:9/9") and not lease.take(done.pk, "lab:9/9")
    assert lease.take(dead.pk, "lab:9/9")
    dead.refresh_from_db()
    assert (dead.worker, dead.attempts, dead.status) == ("lab:9/9", 1, "running")


def test_hand_back_takes_only_this_workers_submissions(course: Course, settings: Any) -> None:
    from robokit.server import lease

    mine = submission(course, status="running", worker="lab:10/11")
    other = submission(course, status="running", worker="lab:100/11")  # a prefix of ours is not ours
    assert lease.hand_back("lab:10", "the worker evaluating it was stopped") == [mine.pk]
    other.refresh_from_db()
    assert other.status == "running"


def test_stale_scratch_folders_are_those_of_processes_that_are_gone(tmp_path: Path) -> None:
    from robokit.server.sandbox import SCRATCH_PREFIX, STALE_UNNAMED, remove_stale_scratch

    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True).stdout.strip()
    names = {"dead": f"{SCRATCH_PREFIX}{gone}-abc", "alive": f"{SCRATCH_PREFIX}{os.getpid()}-abc",
             "old unnamed": f"{SCRATCH_PREFIX}x1y2z3", "young unnamed": f"{SCRATCH_PREFIX}q9w8e7",
             "not ours": "robokit-validate-abc"}
    for name in names.values():
        (tmp_path / name).mkdir()
        (tmp_path / name / "file.py").write_text("x = 1\n")
    old = (tmp_path / names["old unnamed"]).stat().st_mtime - STALE_UNNAMED - 60
    os.utime(tmp_path / names["old unnamed"], (old, old))
    removed = remove_stale_scratch(str(tmp_path))
    assert sorted(removed) == sorted(str(tmp_path / names[k]) for k in ("dead", "old unnamed"))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names[k] for k in ("alive", "young unnamed",
                                                                                   "not ours"))
