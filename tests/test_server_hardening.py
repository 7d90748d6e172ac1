"""The result API refuses every malformed body with a 400 naming the field (never a 500, fuzzed with Hypothesis),
takes only JSON, answers a missing token with the documented 401; pages carry a Content-Security-Policy; the
database and uploads are private; the run page never shows a student's local folders."""

from __future__ import annotations

import json
import os
import re
import sqlite3
import stat
from pathlib import Path
from typing import Any

import pytest
from course_helpers import LESSON_08, PASSWORD, Course, post, robokit_payload, tiny_png
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.server.models import Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

API = "/api/robotics/result/"


def _raw(client: Any, body: bytes, content_type: str = "application/json", **headers: Any) -> Any:
    return client.post(API, data=body, content_type=content_type, **headers)


# --- malformed bodies: 400 naming the field ---------------------------------------------------------------------

HUGE = "9" * 5000  # past Python's 4300-digit int-str limit: int() itself raises ValueError


@pytest.mark.parametrize(("body", "field", "words"), [
    ('{"student": "k", "project": "A", "result": {"score": 1e400}}', "result.score", "too large"),
    ('{"student": "k", "project": "A", "result": {"score": -1e400}}', "result.score", "too large"),
    ('{"student": "k", "project": "A", "result": {"big": ' + "7" * 400 + "}}", "result.big", "64-bit"),
    ('{"student": "k", "project": "A", "notes": ' + HUGE + "}", "notes", "5000 digits"),
    ('{"student": "k", "project": "A", "result": {"objects": [{"x": -' + HUGE + "}]}}",
     "result.objects[0].x", "64-bit"),
    ('{"student": "k", "project": "A", "red_sorted": ' + HUGE + "}", "red_sorted", "64-bit"),
    ('{"student": "k", "project": "A", "result": {"score": Infinity}}', "result.score", "Infinity"),
    ('{"student": "k", "project": "A", "result": {"score": -Infinity}}', "result.score", "-Infinity"),
    ('{"student": "k", "project": "A", "result": {"score": NaN}}', "result.score", "NaN"),
    ('{"student": "k", "project": "A", "result": ' + '{"a": ' * 40 + "1" + "}" * 41,
     "result" + ".a" * 32, "nested more than 32"),
    ('{"student": "k", "project": "A", "result": {"x": ' + "[" * 800 + "]" * 800 + "}}",
     "result.x" + "[0]" * 31, "nested more than 32"),
    ('{"student": "k\\ud800", "project": "A"}', "student", "lone surrogate"),
    ('{"student": "k", "project": "A\\u0000"}', "project", "NUL"),
    ('{"student": "k", "project": "A", "result": {"\\udc00": 1}}', "result", "lone surrogate"),
    ('{"student": "k", "project": "A", "total_time": [1]}', "total_time", "number"),
    ('{"student": "k", "project": "A", "interrupted": "yes"}', "interrupted", "true/false"),
    ('{"student": ["k"], "project": "A"}', "student", "string"),
])
def test_malformed_bodies_are_400_naming_the_field(client: Any, course: Course, body: str, field: str,
                                                   words: str) -> None:
    resp = _raw(client, body.encode("utf-8"))
    assert resp.status_code == 400, resp.content
    answer = resp.json()
    assert answer["field"] == field
    assert answer["error"].startswith(f"{field}: ") and words in answer["error"]
    assert "\n" not in answer["error"] and len(answer["error"]) < 300
    assert Result.objects.count() == 0


def test_numbers_inside_the_limits_are_kept_exactly(client: Any, course: Course) -> None:
    body = {**LESSON_08, "seed": 2**63 - 1, "result": {"score": 1e308, "steps": -(2**63), "deep": [[[[1]]]]}}
    resp = post(client, body)
    assert resp.status_code == 201, resp.content
    row = Result.objects.get()
    assert row.seed == 2**63 - 1 and row.payload["result"]["steps"] == -(2**63)
    assert row.figures["score"] == 1e308


class Raw:
    """Text put into the JSON body as it is (numbers Python's json module would not write, or could not)."""

    def __init__(self, text: str) -> None:
        self.text = text


FIELDS = ["student", "project", "classroom", "run_id", "red_sorted", "blue_sorted", "failures", "total_time",
          "sim_time", "wall_time", "seed", "ticks", "outcome", "result", "interrupted", "schema", "config",
          "objects", "score", "reason"]

_numbers = st.one_of(
    st.integers(), st.integers(min_value=-(2**70), max_value=2**70), st.floats(),
    st.integers(min_value=1, max_value=6000).map(lambda n: Raw("8" * n)),
    st.sampled_from([Raw("1e400"), Raw("-1e400"), Raw("NaN"), Raw("Infinity"), Raw("-Infinity"), Raw("1e-400")]))
_scalars = st.one_of(st.none(), st.booleans(), _numbers, st.text(max_size=12),
                     st.sampled_from(["A", "kim", "1반", "succeeded", "failed", "\ud800", "a\x00b"]))
_values = st.recursive(_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.dictionaries(st.one_of(st.sampled_from(FIELDS), st.text(max_size=6)), inner, max_size=5)), max_leaves=25)
_named = st.fixed_dictionaries(
    {"project": st.one_of(st.just("A"), _scalars), "student": st.one_of(st.just("kim"), _scalars)},
    optional={k: _values for k in FIELDS if k not in ("project", "student")})
_nested = st.integers(min_value=30, max_value=900).map(
    lambda n: Raw('{"project": "A", "student": "kim", "result": ' + "[" * n + "]" * n + "}"))
_bodies = st.one_of(_named, _values, _nested)


def _encode(value: Any) -> bytes:
    raws: list[str] = []

    def swap(v: Any) -> Any:
        if isinstance(v, Raw):
            raws.append(v.text)
            return f"@@RAW{len(raws) - 1}@@"
        if isinstance(v, dict):
            return {k: swap(x) for k, x in v.items()}
        if isinstance(v, list):
            return [swap(x) for x in v]
        return v

    text = json.dumps(swap(value), ensure_ascii=True)
    for i, raw in enumerate(raws):
        text = text.replace(f'"@@RAW{i}@@"', raw)
    return text.encode("utf-8")


@pytest.mark.slow
@settings(max_examples=120, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(body=_bodies, who=st.sampled_from([None, "kim", "teacher", "junk"]), open_class=st.booleans())
def test_fuzz_any_json_ish_body_is_answered_never_a_500(client: Any, course: Course, body: Any, who: str | None,
                                                        open_class: bool) -> None:
    if course.room.allow_unverified != open_class:
        course.room.allow_unverified = open_class
        course.room.save()
    token = {"kim": course.kim_token, "teacher": course.teacher_token, "junk": "rks_junk", None: None}[who]
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    resp = _raw(client, _encode(body), **headers)  # the test client re-raises a view's exception: a 500 fails here
    assert resp.status_code in (200, 201, 400, 401, 403, 409), resp.content
    answer = resp.json()
    if resp.status_code >= 400:
        assert set(answer) == {"error", "field"} and "\n" not in answer["error"]
    else:
        assert Result.objects.filter(run_id=answer["run_id"]).exists()


# --- JSON only ----------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data",
                                          "text/plain; charset=utf-8", "application/jsonx", ""])
def test_only_application_json_is_accepted(client: Any, course: Course, content_type: str) -> None:
    body = json.dumps(LESSON_08).encode()
    resp = client.generic("POST", API, data=body, content_type=content_type)
    assert resp.status_code == 415
    answer = resp.json()
    assert answer["field"] == "Content-Type" and "application/json" in answer["error"]
    assert "\n" not in answer["error"]
    assert Result.objects.count() == 0
    ok = client.generic("POST", API, data=body, content_type="application/json; charset=utf-8")
    assert ok.status_code == 201


# --- the missing-token contract -----------------------------------------------------------------------------------

def test_no_token_to_a_class_that_needs_one_is_401_naming_authorization(client: Any, course: Course) -> None:
    course.room.allow_unverified = False
    course.room.save()
    for body in (LESSON_08, {"project": "A"}, {**LESSON_08, "classroom": "1반"}, robokit_payload(1)):
        resp = post(client, body)
        assert resp.status_code == 401
        answer = resp.json()
        assert set(answer) == {"error", "field"} and answer["field"] == "Authorization"
        assert answer["error"].startswith("no token sent: ") and "ROBOKIT_TOKEN" in answer["error"]
        assert resp["WWW-Authenticate"] == 'Bearer realm="robokit"'
    assert Result.objects.count() == 0


def test_no_token_naming_a_closed_class_beside_an_open_one_is_401(client: Any, course: Course) -> None:
    from robokit.server.models import Classroom

    Classroom.objects.create(name="2반", owner=course.teacher, allow_unverified=False)
    resp = post(client, {**LESSON_08, "classroom": "2반"})
    assert resp.status_code == 401 and resp.json()["error"].startswith("no token sent: class '2반'")
    missing = post(client, {"project": "A"})  # the open class: now it is the name that is missing
    assert missing.status_code == 400 and missing.json()["field"] == "student"


@pytest.mark.parametrize(("header", "words"), [
    ("Bearer rks_nope", "unknown token"), ("Basic a2ltOnB3", "malformed Authorization"),
    ("Bearer", "malformed Authorization"), ("Token abc", "malformed Authorization")])
def test_other_token_refusals_are_401_with_error_and_field(client: Any, course: Course, header: str,
                                                           words: str) -> None:
    resp = _raw(client, json.dumps(LESSON_08).encode(), HTTP_AUTHORIZATION=header)
    assert resp.status_code == 401 and resp.json()["field"] == "Authorization"
    assert resp.json()["error"].startswith(words)


# --- Content-Security-Policy on every page ------------------------------------------------------------------------

def _page_urls(course: Course, run_id: str, artifact_pk: int) -> dict[str, str]:
    """One URL for every named route of the course app (the test fails when a route is added without one)."""
    from robokit.server.models import Project

    project = Project.objects.get(classroom=course.room, name="A")
    room = course.room.pk
    return {
        "home": "/", "login": "/accounts/login/", "logout": "/accounts/logout/", "classroom": f"/classes/{room}/",
        "leaderboard": f"/classes/{room}/projects/{project.pk}/", "history": f"/classes/{room}/students/"
        f"{course.kim.pk}/", "export-csv": f"/classes/{room}/results.csv", "run": f"/runs/{run_id}/",
        "artifact": f"/artifacts/{artifact_pk}/xy.png", "me": "/me/", "me-logout": "/me/logout/",
        "api-result": API, "api-artifacts": f"{API}{run_id}/artifacts/", "replay-viewer": "/replay/viewer.js",
        "replay-script": "/replay/replay.js", "my-training-chart": "/me/training.svg", **_course_work_urls(course),
    }


def _course_work_urls(course: Course) -> dict[str, str]:
    """The course-work pages (assignments, dashboard, grades, moderation) with an assignment and a submission."""
    from course_work import OFFICIAL, make_assignment

    from robokit.server.models import Submission

    a = make_assignment(course.room)
    sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL)
    room, kim = course.room.pk, course.kim.pk
    return {
        "assignment": f"/classes/{room}/assignments/{a.pk}/", "assignment-chart":
        f"/classes/{room}/assignments/{a.pk}/reasons.svg", "dashboard": f"/classes/{room}/students/{kim}/dashboard/",
        "student-chart": f"/classes/{room}/students/{kim}/weekly.svg", "grades-csv": f"/classes/{room}/grades.csv",
        "grades-xlsx": f"/classes/{room}/grades.xlsx",
        "moderate": f"/classes/{room}/moderate/", "moderation": f"/classes/{room}/moderation/",
        "submission": f"/submissions/{sub.pk}/", "reevaluate": f"/submissions/{sub.pk}/reevaluate/",
        "api-submit": f"/api/robotics/assignments/{a.name}/submissions/",
        "api-submission": f"/api/robotics/submissions/{sub.pk}/", "api-training": "/api/robotics/training/",
    }


def test_every_html_page_has_a_content_security_policy(client: Any, course: Course, media: Path) -> None:
    from django.urls import get_resolver
    from django.urls.resolvers import URLPattern

    from robokit.server.middleware import PAGE_CSP

    payload = robokit_payload(1)
    post(client, payload, course.kim_token)
    up = client.post(f"{API}{payload['run_id']}/artifacts/", data={"f": _file("xy.png", tiny_png())},
                     HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    urls = _page_urls(course, payload["run_id"], up.json()["artifacts"][0]["url"].split("/")[2])
    named = {p.name for p in get_resolver().url_patterns if isinstance(p, URLPattern)}
    assert named == set(urls)  # every page of the app is checked below
    admin_urls = ["/admin/", "/admin/password_change/", "/admin/no-such-page/", "/no-such-page/"]
    for model in ("classroom", "student", "token", "project", "result", "assignment", "submission",
                  "moderationevent", "trainingrun"):
        admin_urls += [f"/admin/course/{model}/", f"/admin/course/{model}/1/change/"]
    admin_urls += ["/admin/course/classroom/add/", "/admin/course/student/add/", "/admin/course/project/add/"]
    pages = 0
    for who in ("anonymous", "student", "teacher"):
        client.logout()
        if who == "student":
            client.post("/me/", {"token": course.kim_token})
        if who == "teacher":
            assert client.login(username="teacher", password=PASSWORD)
            course.teacher.is_superuser = True
            course.teacher.save()
        for url in [*urls.values(), *admin_urls, "/admin/login/"]:
            resp = client.get(url)
            if not resp.get("Content-Type", "").startswith("text/html"):
                continue
            pages += 1
            assert resp.get("Content-Security-Policy") == PAGE_CSP, (who, url)
            if resp.status_code == 200:
                html = resp.content.decode()
                assert not re.search(r"<script(?![^>]*\ssrc=)[^>]*>", html), (who, url)  # CSP would block it
                assert not re.search(r"<[^>]+\son[a-z]+\s*=", html), (who, url)
    assert pages >= 40
    policy = dict(part.strip().split(" ", 1) for part in PAGE_CSP.split(";"))
    assert policy["script-src"] == "'self'" and policy["object-src"] == "'none'"
    assert policy["frame-ancestors"] == "'none'" and policy["base-uri"] == "'none'"


def _file(name: str, content: bytes) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    return SimpleUploadedFile(name, content)


@pytest.fixture
def media(settings: Any, tmp_path: Path) -> Path:
    settings.MEDIA_ROOT = tmp_path / "media"
    return Path(settings.MEDIA_ROOT)


# --- private files ------------------------------------------------------------------------------------------------

@pytest.fixture
def open_umask() -> Any:
    old = os.umask(0o022)  # the usual umask: without explicit modes, files come out 0644 and folders 0755
    yield
    os.umask(old)


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_uploads_are_stored_in_private_folders(client: Any, course: Course, media: Path, open_umask: Any) -> None:
    payload = robokit_payload(2)
    post(client, payload, course.kim_token)
    resp = client.post(f"{API}{payload['run_id']}/artifacts/", data={"f": _file("xy.png", tiny_png())},
                       HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert resp.status_code == 201
    stored = media / "artifacts" / payload["run_id"] / "xy.png"
    assert stored.read_bytes() == tiny_png()
    for folder in (media, media / "artifacts", stored.parent):
        assert _mode(folder) == 0o700, folder
    assert _mode(stored) == 0o600


def test_a_new_sqlite_database_and_its_wal_files_are_private(tmp_path: Path, open_umask: Any) -> None:
    from robokit.server.private import private_sqlite

    db = tmp_path / "data" / "db.sqlite3"
    private_sqlite({"ENGINE": "django.db.backends.sqlite3", "NAME": str(db)})
    conn = sqlite3.connect(db)  # the real SQLite, in WAL mode as the server runs it
    conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("CREATE TABLE t (x)")
    conn.execute("INSERT INTO t VALUES (1)")
    conn.commit()
    files = [db, db.with_name("db.sqlite3-wal"), db.with_name("db.sqlite3-shm")]
    assert all(f.exists() for f in files)
    assert [_mode(f) for f in files] == [0o600] * 3 and _mode(db.parent) == 0o700
    conn.close()
    (tmp_path / "loose.sqlite3").touch()
    assert _mode(tmp_path / "loose.sqlite3") == 0o644  # what the umask alone gives: the check above is not vacuous


# --- the run page shows the config's file name --------------------------------------------------------------------

@pytest.mark.parametrize("path", ["/home/kimminjun/robots/configs/sort_robot.toml",
                                  "C:\\Users\\kimminjun\\robots\\sort_robot.toml", "configs/sort_robot.toml"])
def test_run_page_shows_the_config_file_name_not_the_local_path(client: Any, course: Course, path: str) -> None:
    payload = {**robokit_payload(3), "config": path}
    assert post(client, payload, course.kim_token).status_code == 201
    row = Result.objects.get()
    assert row.config == "sort_robot.toml" and row.payload["config"] == "sort_robot.toml"
    assert client.login(username="teacher", password=PASSWORD)
    html = client.get(f"/runs/{payload['run_id']}/").content.decode()
    assert "<code>sort_robot.toml</code>" in html
    assert "kimminjun" not in html and "robots" not in html and "configs/" not in html
    csv_text = client.get(f"/classes/{course.room.pk}/results.csv").content.decode("utf-8-sig")
    assert "kimminjun" not in csv_text and ",sort_robot.toml," in csv_text


def test_rows_stored_before_the_change_are_shown_by_file_name_too(client: Any, course: Course) -> None:
    from robokit.server.models import Project

    project = Project.objects.create(classroom=course.room, name="A")
    old = "/home/kimminjun/sort_robot.toml"
    Result.objects.create(run_id="old-run", classroom=course.room, project=project, student_name="x", config=old,
                          payload={"config": old, "project": "A"})
    assert client.login(username="teacher", password=PASSWORD)
    html = client.get("/runs/old-run/").content.decode()
    assert "sort_robot.toml" in html and "kimminjun" not in html
