"""When a submission is taken, over generated opening and due times (docs/server.md, "Create an assignment" and
"Limits, and a submission sent twice").

Before ``opens`` a submission is refused (403 ``opens_at``); after ``due`` it is stored and marked late, or refused
(403 ``due_at``) where late work is refused; otherwise stored on time. A submission stored is one submission however
often it arrives: the same ``Idempotency-Key`` sent again is answered 200 with it -- also when the resend arrives
after the due time (``robokit submit`` resends when the connection failed before the answer), and it keeps the late
flag it was stored with.

The expected answer is decided here from the generated times against the clock read around the post.
"""

from __future__ import annotations

import datetime as dt
import json
import uuid
from typing import Any

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=12, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
offset = st.one_of(st.none(), st.sampled_from([-90, -1, 1, 90]).map(lambda m: dt.timedelta(minutes=m)))


@pytest.fixture
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False  # stored and queued; nothing is evaluated here


def submit(client: Any, name: str, token: str, config: str, key: str) -> Any:
    return client.post(f"/api/robotics/assignments/{name}/submissions/", data=json.dumps({"config": config}),
                       content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {token}",
                       HTTP_IDEMPOTENCY_KEY=key)


@PROPS
@given(opens=offset, due=offset, refuse=st.booleans())
def test_opening_due_and_late_work_and_a_resend_after_the_due_time(client: Any, course: Any, queued: None,
                                                                    opens: dt.timedelta | None,
                                                                    due: dt.timedelta | None, refuse: bool) -> None:
    from course_work import OFFICIAL, make_assignment
    from django.utils import timezone

    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    now = timezone.now()
    a = make_assignment(course.room, opens_at=now + opens if opens is not None else None,
                        due_at=now + due if due is not None else None, late_policy="refuse" if refuse else "accept",
                        max_waiting=0, max_per_day=0)
    key = uuid.uuid4().hex
    got = submit(client, a.name, course.kim_token, OFFICIAL, key)
    if opens is not None and opens > dt.timedelta(0):
        assert (got.status_code, got.json()["field"]) == (403, "opens_at")
        assert not Submission.objects.exists()
        return
    late = due is not None and due < dt.timedelta(0)
    if late and refuse:
        assert (got.status_code, got.json()["field"]) == (403, "due_at")
        assert not Submission.objects.exists()
        return
    assert got.status_code == 201, got.content
    first = got.json()
    assert first["late"] is late and Submission.objects.get(pk=first["id"]).late is late

    # the deadline passes (late work refused), then the client resends what it sent: the same submission
    Assignment.objects.filter(pk=a.pk).update(due_at=timezone.now() - dt.timedelta(minutes=5), late_policy="refuse")
    again = submit(client, a.name, course.kim_token, OFFICIAL, key)
    assert (again.status_code, again.json()["id"], again.json()["late"]) == (200, first["id"], late), again.content
    assert Submission.objects.count() == 1
    fresh = submit(client, a.name, course.kim_token, OFFICIAL, uuid.uuid4().hex)  # a new one is late: refused
    assert (fresh.status_code, fresh.json()["field"]) == (403, "due_at")


@pytest.mark.parametrize("step", [-1, 0, 1])
def test_the_due_and_opening_instants_themselves(client: Any, course: Any, queued: None, monkeypatch: Any,
                                                 step: int) -> None:
    """On the instant of the due time a submission is on time, a microsecond after it late (refused where late work
    is refused); on the opening instant it is taken, a microsecond before refused. The server's clock is set to
    each instant (``django.utils.timezone.now``), the expected answer decided here from the rule "after due" /
    "before opens"."""
    from course_work import OFFICIAL, make_assignment
    from django.utils import timezone

    from robokit.server.models import Submission

    at = dt.datetime(2026, 12, 4, 9, 0, tzinfo=dt.timezone.utc)
    now = at + dt.timedelta(microseconds=step)
    monkeypatch.setattr(timezone, "now", lambda: now)
    due = make_assignment(course.room, name="due", due_at=at, late_policy="accept", max_waiting=0, max_per_day=0)
    refused = make_assignment(course.room, name="refused", due_at=at, late_policy="refuse", max_waiting=0,
                              max_per_day=0)
    opens = make_assignment(course.room, name="opens", opens_at=at, max_waiting=0, max_per_day=0)
    got = submit(client, due.name, course.kim_token, OFFICIAL, uuid.uuid4().hex)
    assert got.status_code == 201 and got.json()["late"] is (now > at), got.content
    got = submit(client, refused.name, course.kim_token, OFFICIAL, uuid.uuid4().hex)
    if now > at:
        assert (got.status_code, got.json()["field"]) == (403, "due_at")
    else:
        assert got.status_code == 201 and got.json()["late"] is False, got.content
    got = submit(client, opens.name, course.kim_token, OFFICIAL, uuid.uuid4().hex)
    if now < at:
        assert (got.status_code, got.json()["field"]) == (403, "opens_at")
    else:
        assert got.status_code == 201, got.content
    assert Submission.objects.count() == 1 + (now <= at) + (now >= at)
