"""Assignments and submissions: the teacher's command, students' submissions checked against what they may change
and robokit's own validation, deadlines, and the `robokit submit` command against a live server."""

from __future__ import annotations

import datetime as dt
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from course_helpers import Course, post, robokit_payload
from course_work import ALLOWED, OFFICIAL, changed, make_assignment, submit
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False  # these tests look at what is queued; evaluation is test_course_evaluation's


def test_create_assignment_command_stores_config_seeds_keys_and_due(course: Course, tmp_path: Path) -> None:
    from django.core.management import CommandError, call_command

    from robokit.server.models import Assignment

    cfg = tmp_path / "official.toml"
    cfg.write_text(OFFICIAL, encoding="utf-8")
    call_command("create_assignment", "1반", "낙하", "--config", str(cfg), "--allow", "world.max_time",
                 "--allow", "behaviour.*", "--seeds", "3:7", "--due", "2026-12-04T18:00+09:00", "--late", "refuse")
    a = Assignment.objects.get(name="낙하")
    assert a.seeds == [3, 4, 5, 6] and a.kind == "drop_test" and a.late_policy == "refuse"
    assert a.due_at == dt.datetime(2026, 12, 4, 9, 0, tzinfo=dt.timezone.utc)
    assert a.may_change("behaviour.duration") and a.may_change("world.max_time")
    assert not a.may_change("world.seed_x") and not a.may_change("bodies.box.mass")
    assert a.project.name == "낙하" and a.project.classroom == course.room
    assert (a.max_waiting, a.max_per_day) == (1, 10)  # the limits' defaults
    call_command("create_assignment", "1반", "낙하", "--config", str(cfg), "--max-waiting", "2", "--max-per-day", "0")
    a.refresh_from_db()
    assert (a.max_waiting, a.max_per_day) == (2, 0)
    with pytest.raises(CommandError, match="--max-waiting"):
        call_command("create_assignment", "1반", "낙하", "--config", str(cfg), "--max-per-day", "-1")


def test_create_assignment_refuses_an_invalid_official_config_in_one_line(course: Course, tmp_path: Path) -> None:
    from django.core.management import CommandError, call_command

    cfg = tmp_path / "bad.toml"
    cfg.write_text(changed(OFFICIAL, duration='"long"'), encoding="utf-8")
    with pytest.raises(CommandError) as err:
        call_command("create_assignment", "1반", "x", "--config", str(cfg))
    assert "behaviour.duration" in str(err.value) and "\n" not in str(err.value)


def test_a_valid_submission_is_stored_and_queued_in_the_same_transaction(client: Any, course: Course) -> None:
    from django_q.models import OrmQ

    from robokit.server.models import Submission

    make_assignment(course.room)
    resp = submit(client, "낙하 실험", changed(OFFICIAL, duration="0.4"), course.kim_token)
    assert resp.status_code == 201, resp.content
    body = resp.json()
    assert body["student"] == "김민준" and body["late"] is False and body["status"] == "queued" and body["seeds"] == 2
    sub = Submission.objects.get()
    assert sub.student == course.kim and "duration = 0.4" in sub.config_text
    assert OrmQ.objects.count() == 1  # the evaluation task, in the queue's table


@pytest.mark.parametrize(("config", "field"), [
    (changed(OFFICIAL, restitution="0.1"), "bodies.plane.restitution"),       # not an allowed key
    (OFFICIAL.replace("[behaviour]", "[behaviour]\nspeed = 2"), "behaviour.speed"),  # an added key
    (changed(OFFICIAL, duration='"long"'), "behaviour.duration"),               # allowed, but robokit refuses it
    (changed(OFFICIAL, duration="-1"), "behaviour.duration"),
    (changed(OFFICIAL, max_time="[1]"), "world.max_time"),
])
def test_a_refused_config_is_a_one_line_400_naming_the_key(client: Any, course: Course, config: str,
                                                           field: str) -> None:
    from robokit.server.models import Submission

    make_assignment(course.room)
    resp = submit(client, "낙하 실험", config, course.kim_token)
    assert resp.status_code == 400, resp.content
    body = resp.json()
    assert body["field"] == field and body["error"].startswith(field) and "\n" not in body["error"]
    assert not Submission.objects.exists()


def test_a_toml_syntax_error_names_the_config(client: Any, course: Course) -> None:
    make_assignment(course.room)
    resp = submit(client, "낙하 실험", "[world\nseed = 1", course.kim_token)
    assert resp.status_code == 400 and resp.json()["field"] == "config"


def test_late_work_is_marked_or_refused_per_assignment(client: Any, course: Course) -> None:
    from django.utils import timezone

    past = timezone.now() - dt.timedelta(minutes=1)
    make_assignment(course.room, "marked", due_at=past)
    make_assignment(course.room, "refused", due_at=past, late_policy="refuse")
    make_assignment(course.room, "not yet", opens_at=timezone.now() + dt.timedelta(hours=1))
    marked = submit(client, "marked", OFFICIAL, course.kim_token)
    assert marked.status_code == 201 and marked.json()["late"] is True
    refused = submit(client, "refused", OFFICIAL, course.kim_token)
    assert refused.status_code == 403 and refused.json()["field"] == "due_at"
    early = submit(client, "not yet", OFFICIAL, course.kim_token)
    assert early.status_code == 403 and early.json()["field"] == "opens_at"


def test_who_may_submit(client: Any, course: Course) -> None:
    make_assignment(course.room)
    assert submit(client, "낙하 실험", OFFICIAL, None).status_code == 401
    assert submit(client, "낙하 실험", OFFICIAL, "rks_nope").status_code == 401
    teacher = submit(client, "낙하 실험", OFFICIAL, course.teacher_token)
    assert teacher.status_code == 403 and teacher.json()["field"] == "Authorization"
    missing = submit(client, "없는 과제", OFFICIAL, course.kim_token)
    assert missing.status_code == 404 and "'낙하 실험'" in missing.json()["error"]


def test_posting_runs_to_an_assignment_keeps_working(client: Any, course: Course) -> None:
    from robokit.server.models import Result

    a = make_assignment(course.room)
    resp = post(client, robokit_payload(1, project="낙하 실험"), course.kim_token)
    assert resp.status_code == 201
    assert Result.objects.get().project == a.project  # the assignment's project: on its run leaderboard
    client.login(username="teacher", password="correct-horse-battery")
    page = client.get(f"/classes/{course.room.pk}/projects/{a.project.pk}/").content.decode()
    assert "김민준" in page


def test_robokit_submit_command_against_a_live_server(live_server: Any, course: Course, tmp_path: Path) -> None:
    make_assignment(course.room)
    good, bad = tmp_path / "mine.toml", tmp_path / "bad.toml"
    good.write_text(changed(OFFICIAL, duration="0.3"), encoding="utf-8")
    bad.write_text(changed(OFFICIAL, mass="2.0"), encoding="utf-8")
    env = {**os.environ, "ROBOKIT_TOKEN": course.kim_token}
    cmd = [sys.executable, "-m", "robokit.cli", "submit", "낙하 실험"]
    ok = subprocess.run([*cmd, str(good), "--url", live_server.url], env=env, capture_output=True, text=True,
                        timeout=120)
    assert ok.returncode == 0, ok.stderr
    assert ok.stdout.startswith("submitted: submission") and "on 2 seeds" in ok.stdout
    refused = subprocess.run([*cmd, str(bad), "--url", live_server.url + "/api/robotics/result/"], env=env,
                             capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2
    assert refused.stderr.count("\n") == 1 and "bodies.box.mass" in refused.stderr, refused.stderr
    assert ALLOWED[0] in refused.stderr  # it says what may be changed


def test_create_assignment_refuses_trials_that_could_outlast_the_queue_timeout(course: Course, tmp_path: Path,
                                                                               settings: Any) -> None:
    from django.core.management import CommandError, call_command

    settings.QUEUE_TIMEOUT = 600
    cfg = tmp_path / "official.toml"
    cfg.write_text(OFFICIAL, encoding="utf-8")
    with pytest.raises(CommandError, match="ROBOKIT_QUEUE_TIMEOUT"):  # 20 x 60 s + 30 s > 600 s
        call_command("create_assignment", "1반", "x", "--config", str(cfg), "--seeds", "0:20")
    call_command("create_assignment", "1반", "x", "--config", str(cfg), "--seeds", "0:20", "--trial-seconds", "20")


_text = st.one_of(st.text(max_size=40), st.sampled_from([
    OFFICIAL, OFFICIAL.replace("[behaviour]", "[behaviour]\nx = 1"), "[world\n", "world = 1", "\ud800", "a\x00b",
    '{"steps": 1}\n{"steps": -1}', '{"steps": 1, "return": 1e999}', "[" * 50]))
_json = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.floats(allow_nan=False), _text),
                     lambda inner: st.one_of(st.lists(inner, max_size=3),
                                             st.dictionaries(st.text(max_size=6), inner, max_size=3)), max_leaves=12)
_course_bodies = st.one_of(_json, st.fixed_dictionaries({}, optional={
    "config": st.one_of(_text, _json), "log": st.one_of(_text, _json), "run_id": st.one_of(_text, _json),
    "name": st.one_of(_text, _json)}))


@settings(max_examples=50, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(body=_course_bodies, who=st.sampled_from([None, "kim", "teacher", "junk"]),
       url=st.sampled_from(["/api/robotics/assignments/낙하 실험/submissions/", "/api/robotics/training/",
                            "/api/robotics/assignments/nope/submissions/"]))
def test_fuzz_course_endpoints_answer_json_never_a_500(client: Any, course: Course, body: Any, who: str | None,
                                                       url: str) -> None:
    from robokit.server.models import Assignment

    if not Assignment.objects.exists():
        make_assignment(course.room)
    token = {"kim": course.kim_token, "teacher": course.teacher_token, "junk": "rks_junk", None: None}[who]
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    resp = client.post(url, data=json.dumps(body), content_type="application/json", **headers)  # a 500 raises
    assert resp.status_code in (200, 201, 400, 401, 403, 404, 409), resp.content
    if resp.status_code >= 400:
        answer = resp.json()
        assert set(answer) == {"error", "field"} and "\n" not in answer["error"]


def test_the_documented_config_limit_is_the_enforced_one(client: Any, course: Course) -> None:
    """docs/server.md: a config of at most 256 KiB (its UTF-8 bytes). Exactly that is accepted; a byte more is a
    one-line 413 naming the config and both sizes."""
    from robokit.server.models import Submission

    limit = 256 * 1024
    make_assignment(course.room, max_waiting=10)
    comment = "\n# 설명 "  # Korean padding: bytes, not characters, are counted
    base = OFFICIAL + comment
    pad = limit - len(base.encode("utf-8"))
    exact = base + "x" * pad
    assert len(exact.encode("utf-8")) == limit
    assert submit(client, "낙하 실험", exact, course.kim_token).status_code == 201
    over = submit(client, "낙하 실험", exact + "y", course.kim_token)
    body = over.json()
    assert over.status_code == 413 and body["field"] == "config" and "\n" not in body["error"]
    assert f"{limit + 1} bytes" in body["error"] and f"limit is {limit}" in body["error"]
    assert Submission.objects.count() == 1
