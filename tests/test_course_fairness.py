"""A fair share of the evaluation queue, against a real server on loopback: the same Idempotency-Key is the same
submission (also when two identical posts race), the per-assignment limits refuse in one line saying when to try
again, and the queue's tasks serve the student with the least in progress and least recently served first."""

from __future__ import annotations

import datetime as dt
import os
import re
import subprocess
import sys
import threading
import uuid
from pathlib import Path
from typing import Any

import pytest
import requests
from course_helpers import Course
from course_work import OFFICIAL, changed, make_assignment
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture(autouse=True)
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False  # submissions wait in the queue's table; the tests play the workers


def post(url: str, name: str, token: str, config: str, key: str | None = None) -> requests.Response:
    headers = {"Authorization": f"Bearer {token}"}
    if key is not None:
        headers["Idempotency-Key"] = key
    return requests.post(f"{url}/api/robotics/assignments/{name}/submissions/", json={"config": config},
                         headers=headers, timeout=60)


def graded(pk: int) -> None:
    """What a worker leaves behind when it has graded a submission (its evaluation is test_course_evaluation's)."""
    from django.utils import timezone

    from robokit.server.models import Submission

    Submission.objects.filter(pk=pk).update(status=Submission.DONE, finished_at=timezone.now())


def test_two_identical_posts_at_once_make_one_submission(live_server: Any, course: Course) -> None:
    from django_q.models import OrmQ

    from robokit.server.models import Submission

    a = make_assignment(course.room, max_waiting=100, max_per_day=0)
    rounds, answers = 12, []
    for i in range(rounds):
        key, config = uuid.uuid4().hex, changed(OFFICIAL, duration=f"0.{i + 1:02d}")
        start = threading.Barrier(2)
        got: list[requests.Response] = []

        def send(key: str = key, config: str = config, start: threading.Barrier = start,
                 got: list[requests.Response] = got) -> None:
            start.wait()
            got.append(post(live_server.url, a.name, course.kim_token, config, key))

        threads = [threading.Thread(target=send) for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert sorted(r.status_code for r in got) == [200, 201], [r.text for r in got]
        assert got[0].json()["id"] == got[1].json()["id"]
        answers.append(got[0].json()["id"])
        again = post(live_server.url, a.name, course.kim_token, config, key)  # a client's resend, later
        assert again.status_code == 200 and again.json()["id"] == answers[-1]
    assert Submission.objects.count() == rounds == len(set(answers))
    assert OrmQ.objects.count() == rounds  # one evaluation task each
    other = post(live_server.url, a.name, course.kim_token, OFFICIAL, key)  # the key with another config
    assert other.status_code == 409 and other.json()["field"] == "Idempotency-Key"
    lee = post(live_server.url, a.name, course.lee_token, config, key)  # keys are per student
    assert lee.status_code == 201 and lee.json()["student"] == course.lee.name


def test_limits_refuse_in_one_line_saying_when_to_submit_again(live_server: Any, course: Course) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, max_waiting=1, max_per_day=3)
    make_assignment(course.room, "other", max_waiting=1, max_per_day=3)
    first = post(live_server.url, a.name, course.kim_token, OFFICIAL)
    assert first.status_code == 201
    busy = post(live_server.url, a.name, course.kim_token, changed(OFFICIAL, duration="0.2"))
    body = busy.json()
    assert busy.status_code == 429 and body["field"] == "max_waiting" and "\n" not in body["error"]
    assert f"({first.json()['id']})" in body["error"] and "when it is graded" in body["error"]
    assert busy.headers["Retry-After"].isdigit()
    for who, name in ((course.lee_token, a.name), (course.kim_token, "other")):  # others, other assignments
        assert post(live_server.url, name, who, OFFICIAL).status_code == 201
        graded(first.json()["id"])
    for i in range(2):
        ok = post(live_server.url, a.name, course.kim_token, changed(OFFICIAL, duration=f"0.{i + 2}"))
        assert ok.status_code == 201, ok.text
        graded(ok.json()["id"])
    day = post(live_server.url, a.name, course.kim_token, OFFICIAL)
    oldest = Submission.objects.filter(assignment=a, student=course.kim).order_by("submitted_at").first()
    assert oldest is not None
    again = oldest.submitted_at + dt.timedelta(hours=24)
    body = day.json()
    assert day.status_code == 429 and body["field"] == "max_per_day" and "\n" not in body["error"]
    assert again.isoformat(timespec="seconds") in body["error"]
    waited = (again - dt.datetime.now(dt.timezone.utc)).total_seconds()
    assert abs(int(day.headers["Retry-After"]) - waited) < 60
    assert Submission.objects.filter(assignment=a, student=course.kim).count() == 3


@pytest.mark.slow
def test_robokit_submit_prints_a_refusal_in_one_line(live_server: Any, course: Course, tmp_path: Path) -> None:
    a = make_assignment(course.room)
    assert post(live_server.url, a.name, course.kim_token, OFFICIAL).status_code == 201
    mine = tmp_path / "mine.toml"
    mine.write_text(changed(OFFICIAL, duration="0.3"), encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "robokit.cli", "submit", a.name, str(mine), "--url",
                          live_server.url], env={**os.environ, "ROBOKIT_TOKEN": course.kim_token},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "max_waiting" in out.stderr and "when it is graded" in out.stderr


def test_the_queue_serves_each_student_before_one_students_backlog(live_server: Any, course: Course) -> None:
    """Kim posts five, then Lee one: the queue's tasks come in posting order (as django-q's broker hands them
    out); each evaluates the fairest waiting submission, so Lee's comes second (first in, first out would make it
    sixth). With two workers, Lee's is taken while Kim's first is still running."""
    from django_q.models import OrmQ

    from robokit.server.fair_queue import claim
    from robokit.server.models import Submission

    a = make_assignment(course.room, max_waiting=10, max_per_day=0)
    kim = [post(live_server.url, a.name, course.kim_token, changed(OFFICIAL, duration=f"0.{i + 1}")).json()["id"]
           for i in range(5)]
    lee = post(live_server.url, a.name, course.lee_token, OFFICIAL).json()["id"]
    tickets = [int(t.task["args"][0]) for t in OrmQ.objects.order_by("pk")]  # as the broker hands them out
    assert tickets == [*kim, lee]

    order = []
    for ticket in tickets:  # one worker: each task runs to its end before the next
        pk = claim(ticket)
        assert pk is not None
        order.append(pk)
        graded(pk)
    assert order == [kim[0], lee, *kim[1:]]
    assert tickets.index(lee) == 5  # first in, first out would have served it last

    Submission.objects.update(status=Submission.QUEUED, claim=None, claimed_at=None, finished_at=None)
    first = claim(kim[0])  # worker 1 takes Kim's first ...
    second = claim(kim[1])  # ... and worker 2, while it runs, Lee's
    assert (first, second) == (kim[0], lee)
    assert claim(kim[0]) == kim[0]  # a task that comes back (its worker died) resumes its own claim
    graded(first)
    graded(second)
    rest = [claim(t) for t in kim[2:]]
    assert rest == kim[1:4] and claim(lee) == kim[4]  # every task evaluates one, none twice
    assert sorted(Submission.objects.values_list("claim", flat=True)) == sorted(tickets)


@pytest.mark.slow
def test_a_task_evaluates_the_fairest_submission_through_the_sandbox(live_server: Any, course: Course) -> None:
    """The queue's own task function, as a worker calls it, with Kim's second ticket: it evaluates Lee's
    submission for real (official rows on Lee's seeds), and Kim's waits."""
    from robokit.server.evaluation import evaluate_submission
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(3,), max_waiting=10, max_per_day=0)
    kim = [post(live_server.url, a.name, course.kim_token, changed(OFFICIAL, duration=f"0.{i + 1}")).json()["id"]
           for i in range(2)]
    lee = post(live_server.url, a.name, course.lee_token, OFFICIAL).json()["id"]
    graded(kim[0])
    Submission.objects.filter(pk=kim[0]).update(claim=kim[0], claimed_at=dt.datetime.now(dt.timezone.utc))
    assert evaluate_submission(kim[1]) == "done"
    done = Submission.objects.get(pk=lee)
    assert done.status == "done" and done.claim == kim[1] and done.trials == 1
    assert list(Result.objects.filter(submission=done).values_list("seed", "student_name")) == [
        (3, course.lee.name)]
    assert Submission.objects.get(pk=kim[1]).status == "queued"


def test_the_database_itself_refuses_a_second_row_with_the_same_key(course: Course) -> None:
    """The key's uniqueness is the database's (a constraint), not a look-up before the insert."""
    from django.db import IntegrityError, transaction

    from robokit.server.models import Submission

    a = make_assignment(course.room)
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, idempotency_key="k1")
    with pytest.raises(IntegrityError), transaction.atomic():
        Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, idempotency_key="k1")
    Submission.objects.create(assignment=a, student=course.lee, config_text=OFFICIAL, idempotency_key="k1")
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL)  # no key: never a clash
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL)
    assert Submission.objects.count() == 4


@pytest.mark.slow
def test_a_real_worker_serves_another_student_before_a_backlog_and_submit_waits_for_the_grade(
        tmp_path: Path) -> None:
    """``robokit serve`` with one queue worker: Kim posts four submissions, then Lee submits with ``robokit submit
    --wait``. The worker takes Lee's right after the one it is running (first in, first out: fifth), and the
    command returns with Lee's grade."""
    import time

    from course_procs import CourseServer, setup_class

    server = CourseServer(tmp_path / "data", workers=1)
    tokens = setup_class(server, ["김민준", "이서연"])
    official = tmp_path / "official.toml"
    official.write_text(OFFICIAL, encoding="utf-8")
    server.manage("create_assignment", "1반", "낙하", "--config", str(official), "--allow", "behaviour.duration",
                  "--seeds", "0:4", "--max-waiting", "10")
    mine = tmp_path / "mine.toml"
    mine.write_text(changed(OFFICIAL, duration="0.3"), encoding="utf-8")
    env = {**server.env, "ROBOKIT_TOKEN": tokens["이서연"]}
    cmd = [sys.executable, "-m", "robokit.cli", "submit", "낙하", str(mine), "--wait"]
    server.start()
    try:
        alone = time.monotonic()
        first = subprocess.run([*cmd, "--url", server.url], env=env, capture_output=True, text=True, timeout=600)
        alone = time.monotonic() - alone
        assert first.returncode == 0 and "graded: 4/4" in first.stdout, first.stdout + first.stderr
        kim = [post(server.url, "낙하", tokens["김민준"], changed(OFFICIAL, duration=f"0.{i + 2}")).json()["id"]
               for i in range(4)]
        behind = time.monotonic()
        lee_posted = dt.datetime.now(dt.timezone.utc).isoformat(sep=" ")
        lee = subprocess.run([*cmd, "--url", server.url], env=env, capture_output=True, text=True, timeout=600)
        behind = time.monotonic() - behind
        assert lee.returncode == 0 and "graded: 4/4" in lee.stdout, lee.stdout + lee.stderr
        lee_id = int(re.search(r"submission (\d+)", lee.stdout).group(1))  # type: ignore[union-attr]
        done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
        server.wait_for("every submission evaluated", lambda: server.query(done)[0][0] == 6, 600)
        order = [pk for (pk,) in server.query("SELECT id FROM course_submission ORDER BY claimed_at, id")]
        finished = dict(server.query("SELECT id, finished_at FROM course_submission"))
    finally:
        server.stop()
    def utc(when: Any) -> dt.datetime:  # SQLite gives text (UTC, no zone), PostgreSQL a datetime
        when = when if isinstance(when, dt.datetime) else dt.datetime.fromisoformat(when)
        return when if when.tzinfo else when.replace(tzinfo=dt.timezone.utc)

    spans = {pk: (utc(when) - utc(lee_posted)).total_seconds() for pk, when in finished.items()}
    assert order.index(lee_id) <= order.index(kim[1])  # at most Kim's first ran before it
    assert order[-3:] == kim[-3:] or order[-3:] == kim[1:]
    print(f"\nsubmit --wait: {alone:.1f} s alone, {behind:.1f} s behind a 4-submission backlog "
          f"(4 seeds each; one worker); Lee's graded {spans[lee_id]:.1f} s after its post, Kim's last "
          f"{spans[kim[-1]]:.1f} s after it (first in, first out would have graded Lee then); order {order}")


def test_a_re_evaluation_has_a_ticket_of_its_own(client: Any, course: Course) -> None:
    """Kim's second submission was graded by Lee's task while Kim's second task still evaluates Lee's: a teacher's
    re-evaluation of it must not share that busy ticket; its task takes the re-queued submission."""
    from django_q.models import OrmQ

    from robokit.server.fair_queue import claim
    from robokit.server.models import Submission

    a = make_assignment(course.room, max_waiting=10, max_per_day=0)
    k1, k2 = (Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL).pk for _ in "ab")
    l1 = Submission.objects.create(assignment=a, student=course.lee, config_text=OFFICIAL).pk
    assert claim(k1) == k1
    graded(k1)
    assert claim(k2) == l1  # Lee was never served: Kim's second ticket takes Lee's, and is still on it
    assert claim(l1) == k2
    graded(k2)
    client.login(username="teacher", password="correct-horse-battery")
    assert client.post(f"/submissions/{k2}/reevaluate/", {"reason": "a new robokit"}).status_code == 302
    (ticket,) = [t.task["args"][0] for t in OrmQ.objects.all()]
    assert ticket < 0 and claim(ticket) == k2
    assert claim(k2) == l1  # Kim's second ticket still resumes Lee's


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(posts=st.lists(st.integers(0, 2), min_size=1, max_size=12),
       steps=st.lists(st.booleans(), min_size=30, max_size=30))
def test_any_order_of_posts_is_served_fairly(course: Course, posts: list[int], steps: list[bool]) -> None:
    """Generated: three students post in any order, then two workers take and finish submissions in any
    interleaving (each step: take the next task, or finish the oldest running one). At every take, counted plainly
    from the rows: the student served has no more submissions running than any other student with one waiting,
    and among those, was served no later than them; every submission is evaluated once."""
    from robokit.server.fair_queue import claim
    from robokit.server.models import Student, Submission

    Submission.objects.all().delete()
    a = make_assignment(course.room, max_waiting=100, max_per_day=0) if not course.room.assignments.exists() \
        else course.room.assignments.get()
    third = Student.objects.get_or_create(classroom=course.room, name="박지호")[0]
    students = [course.kim, course.lee, third]
    tickets = [Submission.objects.create(assignment=a, student=students[s], config_text=OFFICIAL).pk for s in posts]
    running: list[int] = []
    served: dict[int, int] = {}  # student -> the step it was last served at
    taken = []
    for step, take in enumerate([*steps, *[False] * 2, *[True, False] * len(tickets)]):
        if take and tickets and len(running) < 2:
            rows = list(Submission.objects.values_list("pk", "student_id", "status", "claim"))
            waiting = {s for _, s, status, c in rows if status == "queued" and c is None}
            busy = {s: sum(1 for pk in running if Submission.objects.get(pk=pk).student_id == s) for s in waiting}
            pk = claim(tickets.pop(0))
            if pk is None:
                continue
            who = Submission.objects.get(pk=pk).student_id
            assert busy[who] == min(busy.values())
            fewest = [s for s in waiting if busy[s] == busy[who]]
            assert served.get(who, -1) <= min(served.get(s, -1) for s in fewest)
            served[who] = step
            running.append(pk)
            taken.append(pk)
        elif not take and running:
            graded(running.pop(0))
    assert sorted(taken) == sorted(Submission.objects.values_list("pk", flat=True))
