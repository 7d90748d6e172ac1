"""Official evaluation on a Ray cluster (``ROBOKIT_RAY_ADDRESS``): the trials go through ``robokit sweep``'s Ray
backend, on the cluster's workers, and give the same official rows as the local sandbox."""

from __future__ import annotations

import os
from typing import Any

import pytest
from course_helpers import Course
from course_work import OFFICIAL, changed, make_assignment, submit
from test_sweep_ray import ray_cluster  # noqa: F401 - the fixture: a head and a second node on 127.0.0.1

pytest_plugins = ["course_fixtures"]
pytestmark = [pytest.mark.slow, pytest.mark.django_db]


def test_with_a_ray_address_submissions_are_evaluated_on_the_cluster(client: Any, course: Course, settings: Any,
                                                                     ray_cluster: str,  # noqa: F811
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.server.models import Result, Submission

    settings.QUEUE_SYNC = True
    monkeypatch.setenv("ROBOKIT_RAY_ADDRESS", ray_cluster)
    a = make_assignment(course.room, seeds=(0, 1, 2, 3))
    assert submit(client, a.name, changed(OFFICIAL, duration="0.3"), course.kim_token).status_code == 201
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded, sub.success_rate) == ("done", 4, 4, 1.0), sub.error
    rows = list(Result.objects.filter(submission=sub))
    assert sorted(r.seed for r in rows) == [0, 1, 2, 3]
    workers = {r.payload["worker"] for r in rows}
    assert all(w.rsplit(":", 1)[1] != str(os.getpid()) for w in workers)  # run by Ray's worker processes
    assert {r.reason for r in rows} == {"watched 33 bodies for 0.3 s"}
