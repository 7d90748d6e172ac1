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
