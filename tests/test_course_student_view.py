"""Students see their own official results: each trial's outcome and reason on /me/ and in the API (another
student: 404), `robokit submit --wait` follows a submission to its grade, and a teacher can evaluate a submission
again (recorded in the moderation log). Evaluation is real (the queue run synchronously, trials in the sandbox)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from course_helpers import PASSWORD, Course
from course_work import OFFICIAL, changed, make_assignment, submit

pytest_plugins = ["course_fixtures"]
SHORT = changed(OFFICIAL, max_time="0.2")
"""Stopped at 0.2 sim s, before the 0.5 s drop test ends: aborted on every seed, with the world's reason."""


@pytest.fixture(autouse=True)
def sync_queue(settings: Any) -> None:
    settings.QUEUE_SYNC = True


def own_trials(sub_pk: int) -> list[tuple[int, str, str]]:
    """The official rows of a submission, from the database: what the student must be shown."""
    from robokit.server.models import Result

    return list(Result.objects.filter(submission_id=sub_pk, official=True).order_by("seed")
                .values_list("seed", "outcome", "reason"))


@pytest.mark.django_db
def test_a_student_sees_each_official_trial_of_their_own_submissions(client: Any, course: Course) -> None:
    a = make_assignment(course.room, seeds=(2, 5))
    sub = submit(client, a.name, SHORT, course.kim_token).json()
    rows = own_trials(sub["id"])
    assert [(s, o) for s, o, _ in rows] == [(2, "aborted"), (5, "aborted")]
    assert all("max_time 0.2 s" in r for _, _, r in rows)

    api = client.get(f"/api/robotics/submissions/{sub['id']}/", HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    body = api.json()
    assert api.status_code == 200 and body["status"] == "done" and body["succeeded"] == 0
    assert [(t["seed"], t["outcome"], t["reason"]) for t in body["trials"]] == rows

    client.post("/me/", {"token": course.kim_token})
    page = client.get("/me/").content.decode()
    table = page[page.index(f'id="submission-{sub["id"]}"'):]
    for seed, outcome, reason in rows:
        assert re.search(rf"<td>{seed}</td><td class=\"outcome {outcome}\">{outcome}</td><td>{re.escape(reason)}",
                         table), (seed, table[:2000])

    other = client.get(f"/api/robotics/submissions/{sub['id']}/", HTTP_AUTHORIZATION=f"Bearer {course.lee_token}")
    assert other.status_code == 404
    client.post("/me/", {"token": course.lee_token})
    assert "max_time 0.2 s" not in client.get("/me/").content.decode()


@pytest.mark.slow
@pytest.mark.django_db
def test_a_teacher_evaluates_a_submission_again_and_the_log_says_so(client: Any, course: Course) -> None:
    from django.contrib.auth import get_user_model

    from robokit.server.models import ModerationEvent, Result, Submission

    a = make_assignment(course.room, seeds=(1,))
    sub = submit(client, a.name, SHORT, course.kim_token).json()
    before = set(Result.objects.filter(submission_id=sub["id"]).values_list("pk", flat=True))
    url = f"/submissions/{sub['id']}/reevaluate/"
    assert client.post(url, {"reason": "x"}).status_code == 302  # not logged in: to the login page
    get_user_model().objects.create_user("other", password=PASSWORD)
    client.login(username="other", password=PASSWORD)
    assert client.post(url, {"reason": "x"}).status_code == 404
    client.login(username="teacher", password=PASSWORD)
    assert client.post(url, {"reason": "  "}).status_code == 400
    assert client.post(url, {"reason": "the server was upgraded"}).status_code == 302
    done = Submission.objects.get(pk=sub["id"])
    after = set(Result.objects.filter(submission=done).values_list("pk", flat=True))
    assert done.status == "done" and done.trials == 1 and len(after) == 1 and not after & before
    event = ModerationEvent.objects.get(submission=done)
    assert (event.action, event.reason, event.teacher.username) == ("reevaluate", "the server was upgraded",
                                                                   "teacher")
    log = client.get(f"/classes/{course.room.pk}/moderation/").content.decode()
    assert "reevaluate" in log and "the server was upgraded" in log
    Submission.objects.filter(pk=done.pk).update(status="running")
    assert client.post(url, {"reason": "again"}).status_code == 409  # not while it is being evaluated
    assert ModerationEvent.objects.count() == 1


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_robokit_submit_wait_follows_the_submission_to_its_grade(live_server: Any, course: Course,
                                                                 tmp_path: Path) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, seeds=(0, 3))
    mine = tmp_path / "mine.toml"
    mine.write_text(SHORT, encoding="utf-8")
    start = time.monotonic()
    out = subprocess.run([sys.executable, "-m", "robokit.cli", "submit", a.name, str(mine), "--url",
                          live_server.url, "--wait"], env={**os.environ, "ROBOKIT_TOKEN": course.kim_token},
                         capture_output=True, text=True, timeout=300)
    took = time.monotonic() - start
    assert out.returncode == 0, out.stderr
    sub = Submission.objects.get()
    lines = out.stdout.splitlines()
    assert lines[0].startswith(f"submitted: submission {sub.pk} ")
    trials = [f"  seed {s}: {o} - {r}" for s, o, r in own_trials(sub.pk)]
    assert lines[1:3] == trials and len(trials) == 2
    assert lines[3] == "graded: 0/2 official trials succeeded (success rate 0.00, 95 % 0.00-0.66)"
    assert took < 300


def test_submit_wait_reports_each_change_and_backs_off(httpserver: Any, capsys: Any) -> None:
    """``follow`` against a server that answers queued, queued, running (handed back once: its note), done: one
    line per change, the trials and the grade; the pauses between polls grow from 0.5 s by 1.5x up to 5 s."""
    from robokit.report.submit import follow

    base = {"id": 7, "trials": [], "note": "", "success_rate": None, "wilson95": [None, None], "succeeded": 0}
    note = "re-queued at 10:02 UTC: the worker evaluating it stopped"
    states = [{**base, "status": "queued"}, {**base, "status": "queued"},
              {**base, "status": "running"}, {**base, "status": "queued", "note": note},
              *[{**base, "status": "running", "note": note}] * 4,
              {**base, "status": "done", "succeeded": 1, "success_rate": 0.5, "wilson95": [0.0945, 0.9055],
               "trials": [{"seed": 0, "outcome": "succeeded", "reason": "watched 33 bodies for 0.4 s"},
                          {"seed": 1, "outcome": "failed", "reason": "the cube fell off"}]}]
    for state in states:
        httpserver.expect_ordered_request("/api/robotics/submissions/7/").respond_with_json(state)
    pauses: list[float] = []
    code = follow(httpserver.url_for("/api/robotics/submissions/7/"), {}, 3600, sleep=pauses.append)
    assert code == 0
    assert capsys.readouterr().out.splitlines() == [
        "queued...", "running...", f"queued: {note}...", f"running: {note}...",
        "  seed 0: succeeded - watched 33 bodies for 0.4 s", "  seed 1: failed - the cube fell off",
        "graded: 1/2 official trials succeeded (success rate 0.50, 95 % 0.09-0.91)"]
    expected = [min(0.5 * 1.5 ** i, 5.0) for i in range(len(states) - 1)]
    assert pauses == pytest.approx(expected)


def test_submit_wait_gives_up_after_its_limit_and_says_so(httpserver: Any, capsys: Any) -> None:
    from robokit.report.submit import EXIT_STILL_WAITING, follow

    httpserver.expect_request("/api/robotics/submissions/8/").respond_with_json({"id": 8, "status": "queued"})
    code = follow(httpserver.url_for("/api/robotics/submissions/8/"), {}, 0.0, sleep=lambda s: None)
    err = capsys.readouterr().err
    assert code == EXIT_STILL_WAITING and err.count("\n") == 1 and "still queued after 0 s" in err


def test_submit_wait_stops_at_once_when_the_token_no_longer_sees_the_submission(httpserver: Any,
                                                                                  capsys: Any) -> None:
    from robokit.report.submit import EXIT_REFUSED, follow

    httpserver.expect_request("/api/robotics/submissions/9/").respond_with_json(
        {"error": "Authorization: this token was revoked", "field": "Authorization"}, status=401)
    pauses: list[float] = []
    code = follow(httpserver.url_for("/api/robotics/submissions/9/"), {}, 3600, sleep=pauses.append)
    err = capsys.readouterr().err
    assert code == EXIT_REFUSED and not pauses
    assert err == "robokit: error: cannot follow the submission: Authorization: this token was revoked\n"
