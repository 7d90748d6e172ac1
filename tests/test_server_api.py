"""The course server's API against a real Django and a real SQLite database (pytest-django).

The contract of lesson 08 (201, 200 on a repeated key, 400 naming the field, 413), tokens (recorded as the token's
owner, revoked → 401), artifacts (type checked by content, size capped, idempotent), and robokit's own http reporter
posting to a live server.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

import pytest
import requests
from course_helpers import LESSON_08, Course, mp4_head, post, robokit_payload, tiny_png

from robokit.server.models import Artifact, Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db


def test_lesson_08_payload_exactly_as_the_course_sends_it(client: Any, course: Course) -> None:
    resp = post(client, LESSON_08)
    assert resp.status_code == 201
    body = resp.json()
    assert body["student"] == "홍길동" and body["project"] == "물체 분류"
    assert body["verified"] is False and body["official"] is False
    assert body["figures"] == {"red_sorted": 2, "blue_sorted": 2, "failures": 0, "total_time": 42.5,
                               "sorted_total": 4}
    row = Result.objects.get()
    assert (row.red_sorted, row.blue_sorted, row.failures, row.total_time) == (2, 2, 0, 42.5)
    assert row.classroom == course.room and row.payload == LESSON_08


def test_robokit_payload_201_then_200_with_the_first_record_never_a_second_row(client: Any, course: Course) -> None:
    payload = robokit_payload(1)
    first = post(client, payload, course.kim_token, key=payload["run_id"])
    assert first.status_code == 201
    again = post(client, {**payload, "red_sorted": 0}, course.kim_token, key=payload["run_id"])
    assert again.status_code == 200
    assert again.json() == first.json()  # the record stored the first time, not the second body
    by_run_id = post(client, payload, course.kim_token)  # the run_id alone is the key too
    assert by_run_id.status_code == 200 and by_run_id.json()["id"] == first.json()["id"]
    assert Result.objects.count() == 1
    row = Result.objects.get()
    assert row.outcome == "succeeded" and row.behaviour == "sort" and row.seed == 1 and row.red_sorted == 2


def test_a_key_used_by_another_student_is_a_conflict_not_their_record(client: Any, course: Course) -> None:
    payload = robokit_payload(2)
    assert post(client, payload, course.kim_token).status_code == 201
    resp = post(client, payload, course.lee_token)
    assert resp.status_code == 409 and resp.json()["field"] == "run_id"
    assert "김민준" not in resp.content.decode()
    assert Result.objects.count() == 1


@pytest.mark.parametrize(("body", "field", "words"), [
    (b'{"student": "kim", "project": ', None, "malformed JSON"),
    (b"[1, 2]", None, "expected a JSON object"),
    (b"\xff\xfe", None, "not UTF-8"),
    ({"student": "kim"}, "project", "missing"),
    ({"project": "A", "red_sorted": 1}, "student", "missing"),
    ({**LESSON_08, "blue_sorted": "2"}, "blue_sorted", "whole number"),
    ({**LESSON_08, "red_sorted": 1.5}, "red_sorted", "whole number"),
    ({**LESSON_08, "failures": True}, "failures", "whole number"),
    ({**LESSON_08, "total_time": "42.5"}, "total_time", "number"),
    ({**LESSON_08, "total_time": -1}, "total_time", ">= 0"),
    ({**LESSON_08, "student": 7}, "student", "string"),
    ({**LESSON_08, "student": "   "}, "student", "empty"),
    ({**LESSON_08, "outcome": "won"}, "outcome", "succeeded"),
    ({**LESSON_08, "result": [1]}, "result", "object"),
    ({**LESSON_08, "run_id": "../../etc"}, "run_id", "letters"),
    ({**LESSON_08, "red_sorted": 2**40}, "red_sorted", "from 0 to"),
    ({**LESSON_08, "seed": 2**70}, "seed", "does not fit in a 64-bit whole number"),
    (b'{"student": "kim", "project": "A", "total_time": NaN}', "total_time", "NaN is not a JSON number"),
    (b"[" * 100_000, None, "nested too deeply"),
])
def test_bad_posts_are_400_naming_the_field(client: Any, course: Course, body: Any, field: str | None,
                                            words: str) -> None:
    resp = post(client, body, raw=body if isinstance(body, bytes) else None)
    assert resp.status_code == 400
    answer = resp.json()
    assert answer["field"] == field
    assert words in answer["error"]
    if field:
        assert answer["error"].startswith(f"{field}: ")
    assert Result.objects.count() == 0


def test_idempotency_key_that_disagrees_with_run_id_is_400(client: Any, course: Course) -> None:
    resp = post(client, robokit_payload(3), course.kim_token, key="something-else")
    assert resp.status_code == 400 and resp.json()["field"] == "Idempotency-Key"


def test_oversized_body_is_413_and_nothing_is_stored(client: Any, course: Course) -> None:
    from django.conf import settings

    big = {**LESSON_08, "notes": "x" * (settings.MAX_RESULT_BYTES + 10)}
    resp = post(client, big)
    assert resp.status_code == 413
    assert "limit" in resp.json()["error"]
    assert Result.objects.count() == 0
    assert post(client, {**LESSON_08, "notes": "x" * 1000}).status_code == 201  # a normal one still fits


def test_token_owner_wins_over_the_student_field(client: Any, course: Course) -> None:
    resp = post(client, {**LESSON_08, "student": "<script>alert('x')</script>"}, course.kim_token)
    assert resp.status_code == 201
    row = Result.objects.get()
    assert row.student == course.kim and row.student_name == "김민준" and row.verified
    assert row.posted_student == "<script>alert('x')</script>"  # kept for the teacher, counts for kim


def test_revoked_unknown_and_malformed_tokens_are_401(client: Any, course: Course) -> None:
    from robokit.server.tokens import revoke_student_tokens

    revoke_student_tokens(course.kim)
    resp = post(client, LESSON_08, course.kim_token)
    assert resp.status_code == 401 and "revoked" in resp.json()["error"]
    assert resp["WWW-Authenticate"].startswith("Bearer")
    assert post(client, LESSON_08, "rks_not-a-token").status_code == 401
    basic = client.post("/api/robotics/result/", data=json.dumps(LESSON_08), content_type="application/json",
                        HTTP_AUTHORIZATION="Basic a2ltOnB3")
    assert basic.status_code == 401
    assert Result.objects.count() == 0
    assert course.kim_token not in resp.content.decode()


def test_a_new_token_replaces_the_old_one(client: Any, course: Course) -> None:
    from robokit.server.tokens import hash_token, issue_student_token

    new = issue_student_token(course.kim)
    assert post(client, LESSON_08, course.kim_token).status_code == 401
    assert post(client, LESSON_08, new).status_code == 201
    from robokit.server.models import Token

    assert not Token.objects.filter(key_hash=new).exists()  # only the hash is stored
    assert Token.objects.filter(key_hash=hash_token(new)).exists()


def test_class_that_needs_tokens_refuses_anonymous_posts(client: Any, course: Course) -> None:
    course.room.allow_unverified = False
    course.room.save()
    for body in (LESSON_08, {"project": "A"}):  # no student either: still the token is what is missing
        resp = post(client, body)
        assert resp.status_code == 401 and resp["WWW-Authenticate"].startswith("Bearer")
        assert resp.json()["field"] == "Authorization"
        assert resp.json()["error"].startswith("no token sent: ") and "ROBOKIT_TOKEN" in resp.json()["error"]
    assert post(client, LESSON_08, course.lee_token).status_code == 201


def test_several_open_classes_need_the_class_named(client: Any, course: Course) -> None:
    from robokit.server.models import Classroom

    other = Classroom.objects.create(name="2반", owner=course.teacher, allow_unverified=True)
    resp = post(client, {**LESSON_08, "student": "nobody"})
    assert resp.status_code == 400 and resp.json()["field"] == "classroom"
    ok = post(client, {**LESSON_08, "classroom": "2반"})
    assert ok.status_code == 201 and Result.objects.get().classroom == other
    assert post(client, {**LESSON_08, "student": "김민준"}).json()["classroom"] == "1반"  # a known student's class


def test_teacher_token_posts_are_official(client: Any, course: Course) -> None:
    resp = post(client, robokit_payload(4, student="김민준"), course.teacher_token)
    assert resp.status_code == 201
    body = resp.json()
    assert body["official"] is True and body["verified"] is True and body["student"] == "김민준"
    assert Result.objects.get().student == course.kim


def test_concurrent_posts_with_one_key_store_one_row(live_server: Any, course: Course) -> None:
    payload = robokit_payload(5)
    url = live_server.url + "/api/robotics/result/"
    statuses: list[int] = []
    barrier = threading.Barrier(6)

    def send() -> None:
        barrier.wait()
        r = requests.post(url, json=payload, timeout=30, headers={
            "Idempotency-Key": payload["run_id"], "Authorization": f"Bearer {course.kim_token}"})
        statuses.append(r.status_code)

    threads = [threading.Thread(target=send) for _ in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(statuses) == [200] * 5 + [201]
    assert Result.objects.filter(run_id=payload["run_id"]).count() == 1


def upload(client: Any, run_id: str, files: dict[str, bytes], token: str | None = None) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    data = {f"file{i}": SimpleUploadedFile(name, content) for i, (name, content) in enumerate(files.items())}
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    return client.post(f"/api/robotics/result/{run_id}/artifacts/", data=data, **headers)


@pytest.fixture
def media(settings: Any, tmp_path: Path) -> Path:
    settings.MEDIA_ROOT = tmp_path / "media"
    return settings.MEDIA_ROOT


def test_artifacts_checked_by_content_stored_once(client: Any, course: Course, media: Path) -> None:
    payload = robokit_payload(6)
    assert post(client, payload, course.kim_token).status_code == 201
    run = payload["run_id"]
    svg = b'<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"></svg>'
    files = {"run.mp4": mp4_head(), "timeline.png": tiny_png(), "xy.svg": svg,
             "trace.jsonl": b'{"kind": "transition", "t": 0.5}\n'}
    resp = upload(client, run, files, course.kim_token)
    assert resp.status_code == 201, resp.content
    assert sorted(a["name"] for a in resp.json()["artifacts"]) == sorted(files)
    assert (media / "artifacts" / run / "timeline.png").read_bytes() == tiny_png()
    again = upload(client, run, {"timeline.png": tiny_png()}, course.kim_token)
    assert again.status_code == 200 and Artifact.objects.count() == 4
    clash = upload(client, run, {"timeline.png": tiny_png(5, 5)}, course.kim_token)
    assert clash.status_code == 409


@pytest.mark.parametrize(("name", "content", "words"), [
    ("video.mp4", tiny_png(), "not an MP4"),
    ("plot.png", b"GIF89a" + b"\x00" * 20, "not a PNG"),
    ("plot.svg", b'<svg xmlns="http://www.w3.org/2000/svg"><rect></svg>', "not well-formed"),
    ("plot.svg", b"<html><body>hi</body></html>", "not an SVG"),
    ("run.exe", b"MZ" + b"\x00" * 30, "only"),
    ("trace.jsonl", b"not json\n", "not JSON"),
])
def test_artifacts_with_the_wrong_content_are_refused(client: Any, course: Course, media: Path, name: str,
                                                      content: bytes, words: str) -> None:
    payload = robokit_payload(7)
    post(client, payload, course.kim_token)
    resp = upload(client, payload["run_id"], {name: content}, course.kim_token)
    assert resp.status_code == 400 and words in resp.json()["error"]
    assert Artifact.objects.count() == 0


def test_artifact_size_cap_and_owner_only(client: Any, course: Course, media: Path, settings: Any) -> None:
    payload = robokit_payload(8)
    post(client, payload, course.kim_token)
    settings.MAX_VIDEO_BYTES = 1000
    big = upload(client, payload["run_id"], {"run.mp4": mp4_head() + b"\x00" * 2000}, course.kim_token)
    assert big.status_code == 413 and "limit" in big.json()["error"]
    other = upload(client, payload["run_id"], {"p.png": tiny_png()}, course.lee_token)
    assert other.status_code == 403 and other.json()["field"] == "Authorization"  # a token, not the owner's
    anonymous = upload(client, payload["run_id"], {"p.png": tiny_png()})
    assert anonymous.status_code == 401 and anonymous.json()["error"].startswith("no token sent: ")
    assert upload(client, payload["run_id"], {"p.png": tiny_png()}, course.teacher_token).status_code == 201
    assert upload(client, "no-such-run", {"p.png": tiny_png()}, course.kim_token).status_code == 404


def test_robokit_http_reporter_delivers_to_the_server_unchanged(live_server: Any, course: Course, tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch, settings: Any) -> None:
    from robokit_plugins.http_report import HttpReportConfig, HttpReporter

    settings.MEDIA_ROOT = tmp_path / "media"
    monkeypatch.setenv("COURSE_TOKEN", course.lee_token)
    monkeypatch.chdir(tmp_path)
    payload = robokit_payload(9, student="kim")
    run_dir = tmp_path / "results" / payload["run_id"]
    (run_dir / "plots").mkdir(parents=True)
    (run_dir / "plots" / "xy.png").write_bytes(tiny_png())
    (run_dir / "trace.jsonl").write_text('{"kind": "transition", "t": 0.0, "machine": "behaviour"}\n')
    cfg = HttpReportConfig(url=live_server.url + "/api/robotics/result/", token_env="COURSE_TOKEN",
                           outbox=str(tmp_path / "outbox"), upload_artifacts=True)
    first = HttpReporter("http", cfg).report(payload)
    assert first.delivered and "HTTP 201" in first.message
    assert "artifacts: 2/2 uploaded" in first.message
    second = HttpReporter("http", cfg).report(payload)
    assert second.delivered and "HTTP 200" in second.message
    row = Result.objects.get()
    assert row.student == course.lee and row.verified  # the token's owner, not the payload's "kim"
    assert sorted(a.name for a in row.artifacts.all()) == ["trace.jsonl", "xy.png"]
    assert course.lee_token not in first.message + second.message


def test_upload_artifacts_command_sends_a_run_folder_made_later(live_server: Any, course: Course, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch, settings: Any,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from robokit.cli import main

    settings.MEDIA_ROOT = tmp_path / "media"
    url = live_server.url + "/api/robotics/result/"
    payload = robokit_payload(10)
    requests.post(url, json=payload, headers={"Authorization": f"Bearer {course.kim_token}"}, timeout=30)
    folder = tmp_path / "results" / payload["run_id"]
    folder.mkdir(parents=True)
    (folder / "video.mp4").write_bytes(mp4_head())
    (folder / "notes.txt").write_text("not uploaded")
    monkeypatch.setenv("KIM_TOKEN", course.kim_token)
    args = ["upload-artifacts", payload["run_id"], "--url", url, "--dir", str(tmp_path / "results")]
    assert main([*args, "--token-env", "KIM_TOKEN"]) == 0
    assert "artifacts: 1/1 uploaded" in capsys.readouterr().out
    assert [a.name for a in Artifact.objects.all()] == ["video.mp4"]
    assert main(args) == 1  # without the token: refused (401), said in one line
    assert "video.mp4: HTTP 401" in capsys.readouterr().out
    assert main([*args[:2], "--url", url, "--dir", str(tmp_path / "nowhere")]) == 2
