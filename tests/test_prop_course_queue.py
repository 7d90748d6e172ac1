"""A student's limits and a submission sent twice, over generated histories (docs/server.md, "Limits, and a
submission sent twice").

Per assignment a student may have at most ``max_waiting`` submissions queued or being evaluated, and make at most
``max_per_day`` in any 24 hours (0: no limit); a teacher's re-evaluation counts against neither. Over a limit
nothing is stored and the answer is 429 naming the limit, saying when the student may submit again, with
``Retry-After``. The same ``Idempotency-Key`` is the same submission (200 with it, whatever the limits say); the key
with another config is 409.

Each example stores a generated history for one student -- submissions of any state made up to 40 hours ago, some
of them graded and then evaluated again by the teacher (through the real re-evaluation page), some of another
assignment or another student -- sets generated limits, then posts through the real API. The expected answer is
counted here from the generated history: the waiting ones, the ones inside the last 24 hours, and the moment the
window next has room (the time of the submission whose expiry brings the count under the limit, plus 24 hours).
"""

from __future__ import annotations

import datetime as dt
import re
import uuid
from typing import Any

import pytest
from course_helpers import PASSWORD
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

NOSHRINK = [Phase.explicit, Phase.generate]  # a failing example is printed as generated (a shrink takes minutes)
PROPS = settings(max_examples=12, deadline=None, derandomize=True, database=None, phases=NOSHRINK,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
DAY = dt.timedelta(hours=24)

past = st.fixed_dictionaries({
    "status": st.sampled_from(["queued", "running", "done", "error"]), "minutes_ago": st.integers(1, 2400),
    "again": st.booleans(), "whose": st.sampled_from(["mine", "mine", "mine", "other_assignment", "classmate"])})


@pytest.fixture
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False  # submissions wait in the queue's table; nothing is evaluated


def submit(client: Any, name: str, token: str, config: str, key: str) -> Any:
    import json

    return client.post(f"/api/robotics/assignments/{name}/submissions/", data=json.dumps({"config": config}),
                       content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {token}",
                       HTTP_IDEMPOTENCY_KEY=key)


@PROPS
@given(history=st.lists(past, max_size=8), max_waiting=st.sampled_from([0, 1, 2, 3]),
       max_per_day=st.sampled_from([0, 1, 2, 4]))
def test_limits_and_resends_against_the_history_counted_here(client: Any, course: Any, queued: None,
                                                             history: list[dict[str, Any]], max_waiting: int,
                                                             max_per_day: int) -> None:
    from course_work import OFFICIAL, changed, make_assignment
    from django.utils import timezone

    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    a = make_assignment(course.room, max_waiting=max_waiting, max_per_day=max_per_day)
    b = make_assignment(course.room, name="다른 과제")
    assert client.login(username="teacher", password=PASSWORD)
    start = timezone.now()
    mine: list[dict[str, Any]] = []
    for i, h in enumerate(history):
        owner = course.lee if h["whose"] == "classmate" else course.kim
        where = b if h["whose"] == "other_assignment" else a
        again = h["again"] and h["status"] in ("done", "error")  # only a graded submission is evaluated again
        sub = Submission.objects.create(assignment=where, student=owner, config_text=OFFICIAL, status=h["status"])
        at = start - dt.timedelta(minutes=h["minutes_ago"], microseconds=i)
        Submission.objects.filter(pk=sub.pk).update(submitted_at=at)
        if again:
            answer = client.post(f"/submissions/{sub.pk}/reevaluate/", {"reason": "a new robokit"})
            assert answer.status_code == 302
            assert Submission.objects.get(pk=sub.pk).status == "queued"
        if h["whose"] == "mine":
            mine.append({"at": at, "waiting": h["status"] in ("queued", "running") and not again})
    before = Submission.objects.count()

    waiting = sum(m["waiting"] for m in mine)
    now = timezone.now()
    window = sorted(m["at"] for m in mine if m["at"] > now - DAY)
    key, config = uuid.uuid4().hex, changed(OFFICIAL, duration="0.3")
    got = submit(client, a.name, course.kim_token, config, key)
    if max_waiting and waiting >= max_waiting:
        assert got.status_code == 429 and got.json()["field"] == "max_waiting", got.content
        assert f"you already have {waiting} submission(s)" in got.json()["error"]
        assert got["Retry-After"] == "60"
    elif max_per_day and len(window) >= max_per_day:
        assert got.status_code == 429 and got.json()["field"] == "max_per_day", got.content
        room_at = window[len(window) - max_per_day] + DAY  # then fewer than the limit are left in the window
        text = got.json()["error"]
        assert f"you have made {len(window)} submissions" in text
        assert re.search(r"you may submit again at (\S+)$", text)[1] == room_at.isoformat(timespec="seconds")
        assert abs(int(got["Retry-After"]) - max(1, (room_at - now).total_seconds())) <= 2
    else:
        assert got.status_code == 201, got.content
        sub = got.json()
        assert (sub["status"], sub["late"]) == ("queued", False)
        assert submit(client, a.name, course.kim_token, config, key).json()["id"] == sub["id"]  # a resend: 200
        resend = submit(client, a.name, course.kim_token, config, key)
        assert (resend.status_code, resend.json()["id"]) == (200, sub["id"])
        other = submit(client, a.name, course.kim_token, changed(OFFICIAL, duration="0.4"), key)
        assert (other.status_code, other.json()["field"]) == (409, "Idempotency-Key")
        assert Submission.objects.count() == before + 1
        return
    assert Submission.objects.count() == before  # refused: nothing stored
    assert submit(client, a.name, course.kim_token, config, key).status_code == 429  # and the key is still free
