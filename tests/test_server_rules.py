"""The server's rules as docs/server.md states them, each expectation computed from the rule, not from the code:
which ``Authorization`` headers are accepted, a re-post of someone else's run id, counts and their
bounds, how much of an upload the content checks read, the per-run file cap, and the leaderboard's ranking."""

from __future__ import annotations

import json
import re
from typing import Any

import pytest
from course_helpers import LESSON_08, PASSWORD, Course, mp4_head, post, robokit_payload, tiny_png
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.server.models import Artifact, Project, Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

API = "/api/robotics/result/"


def _with_header(client: Any, header: str | None, body: dict[str, Any] = LESSON_08) -> Any:
    extra = {} if header is None else {"HTTP_AUTHORIZATION": header}
    return client.post(API, data=json.dumps(body), content_type="application/json", **extra)


# --- Authorization: "Bearer <token>", the scheme in any letter case, nothing else ---------------------------------

@pytest.mark.parametrize("form", ["Bearer {t}", "bearer {t}", "BEARER {t}", "BeArEr {t}", "  Bearer {t}  ",
                                  "Bearer   {t}"])
def test_bearer_in_any_case_is_accepted(client: Any, course: Course, form: str) -> None:
    resp = _with_header(client, form.format(t=course.kim_token))
    assert resp.status_code == 201
    assert resp.json()["verified"] is True and resp.json()["student"] == "김민준"


@pytest.mark.parametrize("form", ["{t}", "Basic {t}", "Token {t}", "Bearer:{t}", "Bearer", "Bearer ",
                                  "Bearer {t} extra", "Bearer {t}x", "Bearer x{t}", "Bearer\t{t}", "JWT {t}"])
def test_every_other_authorization_header_is_401_and_stores_nothing(client: Any, course: Course, form: str) -> None:
    resp = _with_header(client, form.format(t=course.kim_token))
    assert resp.status_code == 401 and resp.json()["field"] == "Authorization"
    assert Result.objects.count() == 0  # never stored as an unverified post instead (the class accepts those)


def test_an_empty_authorization_header_is_no_header(client: Any, course: Course) -> None:
    resp = _with_header(client, "")
    assert resp.status_code == 201 and resp.json()["verified"] is False


# --- a run id belongs to whoever posted it first -----------------------------------------------------------------

def test_an_anonymous_repost_of_a_verified_run_id_is_409_and_changes_nothing(client: Any, course: Course) -> None:
    payload = robokit_payload(1)
    first = post(client, payload, course.kim_token)
    assert first.status_code == 201
    for key in (None, payload["run_id"]):
        again = post(client, {**payload, "student": "mallory", "red_sorted": 0}, key=key)
        assert again.status_code == 409 and again.json()["field"] == "run_id"
        assert "김민준" not in again.content.decode()  # nothing of the first post is handed back
    teacher = post(client, payload, course.teacher_token)  # a teacher token is someone else too
    assert teacher.status_code == 409
    row = Result.objects.get()
    assert (row.student_name, row.red_sorted, row.verified) == ("김민준", 2, True)


def test_an_unverified_run_id_reposted_anonymously_is_the_same_run(client: Any, course: Course) -> None:
    body = {**LESSON_08, "run_id": "lesson-08-run-1"}
    assert post(client, body).status_code == 201
    assert post(client, body).status_code == 200  # no token both times: the same owner ("nobody")
    assert post(client, body, course.kim_token).status_code == 409  # a token may not claim it
    assert Result.objects.count() == 1


# --- counts: whole numbers from 0 to 2**31 - 1; times: numbers >= 0 -----------------------------------------------

@pytest.mark.parametrize("field", ["red_sorted", "blue_sorted", "failures"])
@pytest.mark.parametrize(("value", "ok"), [(0, True), (1, True), (2**31 - 1, True), (-1, False), (-(2**31), False),
                                           (2**31, False), (0.0, False), (-0.5, False)])
def test_counts_are_whole_numbers_from_zero(client: Any, course: Course, field: str, value: Any, ok: bool) -> None:
    resp = post(client, {**LESSON_08, field: value})
    assert resp.status_code == (201 if ok else 400)
    if ok:
        assert getattr(Result.objects.get(), field) == value
    else:
        assert resp.json()["field"] == field and Result.objects.count() == 0


@pytest.mark.parametrize("field", ["total_time", "sim_time", "wall_time"])
@pytest.mark.parametrize(("value", "ok"), [(0, True), (0.0, True), (1e-9, True), (3600.5, True), (-1e-9, False),
                                           (-1, False), (True, False)])
def test_times_are_numbers_from_zero(client: Any, course: Course, field: str, value: Any, ok: bool) -> None:
    resp = post(client, {**LESSON_08, field: value})
    assert resp.status_code == (201 if ok else 400), resp.content
    if not ok:
        assert resp.json()["field"] == field


# --- what the content checks read: binary kinds their first bytes, text kinds all of it ---------------------------

def _upload(client: Any, course: Course, run: int, files: dict[str, bytes]) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    payload = robokit_payload(run)
    if not Result.objects.filter(run_id=payload["run_id"]).exists():
        post(client, payload, course.kim_token)
    data = {f"f{i}": SimpleUploadedFile(name, content) for i, (name, content) in enumerate(files.items())}
    return client.post(f"{API}{payload['run_id']}/artifacts/", data=data,
                       HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")


@pytest.fixture
def media(settings: Any, tmp_path: Any) -> Any:
    settings.MEDIA_ROOT = tmp_path / "media"
    return settings.MEDIA_ROOT


@pytest.mark.parametrize(("name", "content", "ok"), [
    ("v.mp4", mp4_head(), True),
    ("v.mp4", b"\x00\x00\x00\x18ftyp" + b"\xff" * 5000, True),  # the docs' rule: an ftyp box at byte 4, no more
    ("v.mp4", b"\x00\x00\x00\x00\x18ftyp" + b"\x00" * 64, False),  # ftyp at byte 5
    ("v.mp4", b"\x00\x00\x00\x18FTYP" + b"\x00" * 64, False),
    ("v.mp4", b"\x00\x00\x00\x18ftyp", False),  # shorter than a box header and brand
    ("p.png", tiny_png(), True),
    ("p.png", b"\x89PNG\r\n\x1a\n" + b"\x00" * 4000, True),  # the signature is what is checked
    ("p.png", b" \x89PNG\r\n\x1a\n" + b"\x00" * 64, False),
    ("p.png", b"\x89PNG\r\n\x1a", False),
])
def test_binary_kinds_are_judged_by_their_first_bytes(client: Any, course: Course, media: Any, name: str,
                                                       content: bytes, ok: bool) -> None:
    resp = _upload(client, course, 1, {name: content})
    assert resp.status_code == (201 if ok else 400), resp.content


@pytest.mark.parametrize(("name", "good", "bad_end"), [
    ("trace.jsonl", b'{"kind": "transition", "t": 0.5}\n', b"not json\n"),
    ("config.toml", b'key = "value"\n', b"= broken\n"),
    ("config.toml", b"# comment line\n", b"\xff\xfe\n"),
])
def test_text_kinds_are_read_to_their_last_byte(client: Any, course: Course, media: Any, name: str, good: bytes,
                                                 bad_end: bytes) -> None:
    body = good * (200_000 // len(good))  # ~200 kB of good lines: far past any head a check might read
    if name.endswith(".toml"):
        body = b"".join(good.replace(b"key", f"k{i}".encode()) for i in range(5000))
    assert _upload(client, course, 2, {name: body}).status_code == 201
    resp = _upload(client, course, 3, {name: body + bad_end})
    assert resp.status_code == 400 and name in resp.json()["error"]


# --- the per-run file cap counts what is already stored ----------------------------------------------------------

def test_file_cap_counts_stored_files_and_resending_one_is_not_new(client: Any, course: Course, media: Any,
                                                                    settings: Any) -> None:
    settings.MAX_ARTIFACTS_PER_RUN = 3
    pngs = {f"p{i}.png": tiny_png(i + 1, 1) for i in range(4)}
    first_two = dict(list(pngs.items())[:2])
    assert _upload(client, course, 4, first_two).status_code == 201
    over = _upload(client, course, 4, dict(list(pngs.items())[2:]))  # 2 stored + 2 new = 4 > 3
    assert over.status_code == 400 and over.json()["field"] == "file" and "at most 3" in over.json()["error"]
    assert Artifact.objects.count() == 2  # nothing of the refused upload was kept
    assert _upload(client, course, 4, {"p2.png": pngs["p2.png"]}).status_code == 201  # 3 = the cap
    again = _upload(client, course, 4, dict(list(pngs.items())[:3]))  # all three again: nothing new
    assert again.status_code == 200 and Artifact.objects.count() == 3
    assert _upload(client, course, 4, {"p3.png": pngs["p3.png"]}).status_code == 400


# --- ranking: the rule of docs/server.md ---------------------------------------------------------------------------

STUDENTS = ["s0", "s1", "s2"]


def _expected_board(runs: list[dict[str, Any]]) -> list[str]:
    """docs/server.md: each student's best run, best first; successful (or outcome-less) runs first, then
    ``-sorted_total,failures,total_time`` (sorted_total = the sum of the *_sorted counts, '-' = higher is
    better); of equal runs the earlier. Returns run ids in board order."""
    def key(i: int) -> tuple[Any, ...]:
        r = runs[i]
        ok = r.get("outcome") in (None, "succeeded")
        return (0 if ok else 1, -(r["red_sorted"] + r["blue_sorted"]), r["failures"], r["total_time"], i)

    best: dict[str, int] = {}
    for i, r in enumerate(runs):
        if r["student"] not in best or key(i) < key(best[r["student"]]):
            best[r["student"]] = i
    return [runs[i]["run_id"] for i in sorted(best.values(), key=key)]


def _board(client: Any, course: Course, table: str, query: str = "") -> list[str]:
    project = Project.objects.get(classroom=course.room, name="R")
    html = client.get(f"/classes/{course.room.pk}/projects/{project.pk}/{query}").content.decode()
    section = html[html.index(f'id="{table}"'):]
    section = section[:section.index("</section>")]
    return re.findall(r'<td><a href="/runs/([^/]+)/"', section)


_run = st.fixed_dictionaries({
    "student": st.sampled_from(STUDENTS), "red_sorted": st.integers(0, 3), "blue_sorted": st.integers(0, 3),
    "failures": st.integers(0, 2), "total_time": st.sampled_from([5.0, 7.5, 7.5, 9.0, 12.25]),
    "outcome": st.sampled_from([None, "succeeded", "failed", "aborted"])})


@settings(max_examples=10, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(runs=st.lists(_run, min_size=1, max_size=7))
def test_leaderboard_follows_the_documented_ranking(client: Any, course: Course, runs: list[dict[str, Any]]) -> None:
    Result.objects.all().delete()
    Project.objects.filter(name="R").delete()
    if "_auth_user_id" not in client.session:
        client.login(username="teacher", password=PASSWORD)
    for i, run in enumerate(runs):
        run["run_id"] = f"rank-{i}"
        body = {k: v for k, v in {**run, "project": "R"}.items() if v is not None}
        assert post(client, body).status_code == 201
    assert Project.objects.get(name="R").ranking == "-sorted_total,failures,total_time"  # the documented default
    assert _board(client, course, "unverified") == _expected_board(runs)


def test_sorting_by_a_column_puts_each_students_best_by_that_figure_first(client: Any, course: Course) -> None:
    runs = [{"student": "s0", "red_sorted": 3, "blue_sorted": 3, "failures": 0, "total_time": 20.0},
            {"student": "s0", "red_sorted": 0, "blue_sorted": 1, "failures": 2, "total_time": 4.0},
            {"student": "s1", "red_sorted": 2, "blue_sorted": 2, "failures": 1, "total_time": 6.0},
            {"student": "s2", "red_sorted": 1, "blue_sorted": 0, "failures": 0, "total_time": 5.0}]
    for i, run in enumerate(runs):
        post(client, {**run, "project": "R", "run_id": f"col-{i}"})
    client.login(username="teacher", password=PASSWORD)
    # By total_time ascending: s0's fastest run (4.0) is their best, then s2 (5.0), then s1 (6.0).
    assert _board(client, course, "unverified", "?sort=total_time&order=asc") == ["col-1", "col-3", "col-2"]
    # By the ranking: s0 (6 sorted), s1 (4), s2 (1).
    assert _board(client, course, "unverified") == ["col-0", "col-2", "col-3"]
    # failures, higher first ("desc"): s0's 2, s1's 1, s2's 0.
    assert _board(client, course, "unverified", "?sort=failures&order=desc") == ["col-1", "col-2", "col-3"]


@pytest.mark.parametrize(("figures", "ranking"), [
    ({"red_sorted": 1, "blue_sorted": 2, "failures": 0, "total_time": 3.0}, "-sorted_total,failures,total_time"),
    ({"collected": 4, "collisions": 1, "total_time": 3.0}, "-collected,collisions,total_time"),
    ({"objects_collected": 4, "collisions": 0, "total_time": 3.0}, "-objects_collected,collisions,total_time"),
    ({"total_time": 3.0}, "total_time"),
])
def test_a_new_projects_ranking_is_the_documented_default(client: Any, course: Course, figures: dict[str, Any],
                                                          ranking: str) -> None:
    assert post(client, {"student": "s0", "project": "new", **figures}).status_code == 201
    assert Project.objects.get(name="new").ranking == ranking
