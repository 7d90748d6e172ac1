"""The daily limit's "submit again at" is the earliest moment the server takes a new submission (docs/server.md,
"Limits, and a submission sent twice").

A student over ``max_per_day`` is refused with the time the 24-hour window next has room (and ``Retry-After``). Over
generated histories (submissions up to 40 hours old, limits 1..4, a teacher who may have lowered the limit below what
the student had made) the answer is judged by the limit itself, asked again at the moments it names: a second after
the ``Retry-After`` the same student is admitted, a second before it they are still refused.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=15, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def admitted(assignment: Any, student_id: int, now: dt.datetime) -> int | None:
    """None when a submission made at ``now`` is taken, else the Retry-After (seconds) of the refusal."""
    from django.db import transaction

    from robokit.server.fair_queue import LimitReached, admit

    try:
        with transaction.atomic():
            admit(assignment, student_id, now=now)
    except LimitReached as exc:
        assert exc.field == "max_per_day", exc.message
        return exc.retry_after
    return None


@PROPS
@given(minutes=st.lists(st.integers(1, 2400), min_size=1, max_size=7, unique=True), limit=st.integers(1, 4))
def test_the_named_moment_is_the_first_the_window_has_room(course: Any, minutes: list[int], limit: int) -> None:
    from course_work import OFFICIAL, make_assignment
    from django.utils import timezone

    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    a = make_assignment(course.room, max_waiting=0, max_per_day=limit)
    now = timezone.now().replace(microsecond=0)
    for m in minutes:
        sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done")
        Submission.objects.filter(pk=sub.pk).update(submitted_at=now - dt.timedelta(minutes=m))
    other = Submission.objects.create(assignment=a, student=course.lee, config_text=OFFICIAL, status="done")
    assert other.pk  # a classmate's submission counts for nobody else
    in_window = sum(m < 24 * 60 for m in minutes)
    wait = admitted(a, course.kim.pk, now)
    if in_window < limit:
        assert wait is None
        return
    assert wait is not None and wait >= 1
    second = dt.timedelta(seconds=1)
    assert admitted(a, course.kim.pk, now + dt.timedelta(seconds=wait) + second) is None, \
        f"still refused after the Retry-After of {wait} s"
    assert admitted(a, course.kim.pk, now + dt.timedelta(seconds=wait) - second) is not None, \
        f"admitted before the Retry-After of {wait} s"
