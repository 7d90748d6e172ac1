"""The evaluation queue's fairness, judged from the rows themselves: whoever was served last, the next claim goes to
a student with the fewest submissions being evaluated now (the first rule of docs/server.md's fair queue); only
among those does "served least recently" decide.

The case the rule order matters for: Kim was served first and is still being evaluated; Lee was served after Kim
and is already graded. Kim was served less recently, but Lee has none running, so Lee's next submission goes first.
"""

from __future__ import annotations

from typing import Any

import pytest
from course_work import OFFICIAL, make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db


@pytest.mark.parametrize("first", ["kim", "lee"])
def test_the_next_claim_goes_to_a_student_with_the_fewest_running(course: Any, settings: Any, first: str) -> None:
    from django.utils import timezone

    from robokit.server.fair_queue import claim
    from robokit.server.models import Submission

    settings.QUEUE_SYNC = False  # the queue decides; this test plays the workers
    a = make_assignment(course.room, max_waiting=100, max_per_day=0)
    early, late = (course.kim, course.lee) if first == "kim" else (course.lee, course.kim)
    subs = [Submission.objects.create(assignment=a, student=s, config_text=OFFICIAL).pk
            for s in (early, late, early, late)]
    assert claim(subs[0]) == subs[0]  # early's first: nobody served yet, the oldest
    assert claim(subs[1]) == subs[1]  # then late's first
    Submission.objects.filter(pk=subs[1]).update(status=Submission.DONE, finished_at=timezone.now())
    rows = list(Submission.objects.values_list("pk", "student_id", "status", "claim"))
    running = {s: sum(1 for _, who, status, c in rows if who == s and c is not None
                      and status not in (Submission.DONE, Submission.ERROR)) for s in (early.pk, late.pk)}
    assert running == {early.pk: 1, late.pk: 0}
    picked = claim(subs[2])
    who = Submission.objects.get(pk=picked).student_id
    assert running[who] == min(running.values())
    assert picked == subs[3]  # late's second: late has none running
