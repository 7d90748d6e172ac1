"""The evaluation queue's fairness, judged from the rows themselves: whoever was served last, the next claim goes to
a student with the fewest submissions being evaluated now (the first rule of docs/server.md's fair queue); only
among those does "served least recently" decide.

The case the rule order matters for: Kim was served first and is still being evaluated; Lee was served after Kim
and is already graded. Kim was served less recently, but Lee has none running, so Lee's next submission goes first.

Rankings, judged by a plain second computation: a run that lacks a ranked figure comes after every run that has it,
whatever the values (lower- or higher-is-better).
"""

from __future__ import annotations

import datetime as dt
from types import SimpleNamespace
from typing import Any

import pytest
from course_work import OFFICIAL, changed, make_assignment

pytest_plugins = ["course_fixtures"]


@pytest.mark.django_db
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


T0 = dt.datetime(2026, 1, 1, tzinfo=dt.timezone.utc)


def _run(pk: int, student: int, figures: dict[str, float]) -> SimpleNamespace:
    return SimpleNamespace(pk=pk, student_id=student, student_name=f"s{student}", outcome="succeeded",
                           figures=figures, received_at=T0 + dt.timedelta(seconds=pk))


@pytest.mark.parametrize("higher", [False, True])
def test_a_run_missing_the_ranked_figure_ranks_after_every_run_with_it(higher: bool) -> None:
    from robokit.server.ranking import best_per_student, sort_key

    values = [-3.0, 0.0, 0.5, 12.0]
    runs = [_run(i + 1, i + 1, {"total_time": v}) for i, v in enumerate(values)]
    missing = [_run(10, 10, {}), _run(11, 11, {"other": 1.0})]
    keys = [("total_time", higher)]
    ranked = best_per_student([*missing, *runs], keys)
    with_figure = [r for r in ranked if "total_time" in r.figures]
    assert ranked[:len(with_figure)] == with_figure  # every run with the figure first
    assert [r.figures["total_time"] for r in with_figure] == sorted(values, reverse=higher)
    # and a student's own best is never their run without the figure
    mine = [_run(20, 5, {}), _run(21, 5, {"total_time": 99.0})]
    assert best_per_student(mine, keys)[0].pk == 21
    assert sort_key(mine[1], keys) < sort_key(mine[0], keys)


@pytest.mark.django_db
@pytest.mark.parametrize("same_config", [True, False])
def test_an_idempotency_key_is_each_students_own(client: Any, course: Any, settings: Any, same_config: bool) -> None:
    """Two students who happen to send the same Idempotency-Key make two submissions, each their own (a key names a
    student's resend, never another student's submission), counted in the table itself."""
    import json

    from robokit.server.models import Submission

    settings.QUEUE_SYNC = False  # stored and queued; no evaluation here
    a = make_assignment(course.room, max_waiting=100, max_per_day=0)
    url = f"/api/robotics/assignments/{a.name}/submissions/"
    configs = {"kim": OFFICIAL, "lee": OFFICIAL if same_config else changed(OFFICIAL, duration="0.25")}
    answers = {}
    for who, token in (("kim", course.kim_token), ("lee", course.lee_token)):
        resp = client.post(url, data=json.dumps({"config": configs[who]}), content_type="application/json",
                           HTTP_AUTHORIZATION=f"Bearer {token}", HTTP_IDEMPOTENCY_KEY="same-key-1")
        answers[who] = (resp.status_code, resp.json())
    assert answers["kim"][0] == answers["lee"][0] == 201, answers
    rows = sorted(Submission.objects.filter(assignment=a).values_list("student__name", "idempotency_key"))
    assert rows == sorted([(course.kim.name, "same-key-1"), (course.lee.name, "same-key-1")])
    assert answers["lee"][1]["student"] == course.lee.name
