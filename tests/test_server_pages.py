"""The teacher's pages and a student's own page, rendered by real Django views from a real SQLite database."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import pytest
from course_helpers import LESSON_08, PASSWORD, Course, mp4_head, post, robokit_payload, tiny_png

from robokit.server.models import Project, Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

SCRIPT = "<script>alert('x')</script>"


@pytest.fixture
def teacher_client(client: Any, course: Course) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


def _project(name: str = "A") -> Project:
    return Project.objects.get(name=name)


def test_pages_need_the_teacher_login(client: Any, course: Course) -> None:
    post(client, robokit_payload(1), course.kim_token)
    for url in (f"/classes/{course.room.pk}/", f"/classes/{course.room.pk}/projects/{_project().pk}/",
                f"/classes/{course.room.pk}/results.csv", f"/runs/{robokit_payload(1)['run_id']}/"):
        resp = client.get(url)
        assert resp.status_code == 302 and resp["Location"].startswith("/accounts/login/")


def test_login_page_logs_the_teacher_in(client: Any, course: Course) -> None:
    resp = client.post("/accounts/login/", {"username": "teacher", "password": PASSWORD, "next": "/"})
    assert resp.status_code == 302
    home = client.get("/")
    assert "1반" in home.content.decode()


def test_leaderboard_best_verified_run_per_student_official_apart(teacher_client: Any, course: Course) -> None:
    c = teacher_client
    post(c, robokit_payload(1, total_time=9.0, red_sorted=2, blue_sorted=2, failures=1), course.kim_token)
    post(c, robokit_payload(2, total_time=7.0, red_sorted=2, blue_sorted=2, failures=0), course.kim_token)
    post(c, robokit_payload(3, total_time=5.0, red_sorted=1, blue_sorted=1, failures=0), course.lee_token)
    post(c, robokit_payload(4, student="김민준", total_time=6.5, red_sorted=2, blue_sorted=2, failures=0),
         course.teacher_token)
    post(c, {**LESSON_08, "project": "A"})  # unverified, listed apart
    resp = c.get(f"/classes/{course.room.pk}/projects/{_project().pk}/")
    html = resp.content.decode()
    assert resp.status_code == 200
    students = html[html.index('id="students"'):html.index('id="official"')]
    assert students.count("<tr><td>") == 2  # one row per student, not per run
    assert students.index("김민준") < students.index("&lt;script&gt;")  # 4 sorted beats 2 sorted
    assert "/runs/00000000-0000-4000-8000-000000000002/" in students  # kim's best: the 7 s run
    assert "/runs/00000000-0000-4000-8000-000000000001/" not in students
    official = html[html.index('id="official"'):html.index('id="unverified"')]
    assert "/runs/00000000-0000-4000-8000-000000000004/" in official
    assert "홍길동" in html[html.index('id="unverified"'):]
    by_time = c.get(f"/classes/{course.room.pk}/projects/{_project().pk}/?sort=total_time&order=asc").content.decode()
    section = by_time[by_time.index('id="students"'):by_time.index('id="official"')]
    assert section.index("&lt;script&gt;") < section.index("김민준")  # 5 s first when sorted by time


def test_names_with_html_and_korean_are_shown_as_text(teacher_client: Any, course: Course) -> None:
    post(teacher_client, {**LESSON_08, "student": SCRIPT + "<b>bold</b>"})
    post(teacher_client, robokit_payload(2), course.lee_token)
    pages = [f"/classes/{course.room.pk}/", f"/classes/{course.room.pk}/projects/{_project('물체 분류').pk}/",
             f"/classes/{course.room.pk}/projects/{_project('A').pk}/", f"/runs/{robokit_payload(2)['run_id']}/",
             f"/classes/{course.room.pk}/students/{course.lee.pk}/"]
    for url in pages:
        html = teacher_client.get(url).content.decode()
        assert "<script>alert" not in html and "<b>bold" not in html, url
        assert "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;" in html, url
    assert "김민준" in teacher_client.get(f"/classes/{course.room.pk}/").content.decode()


def test_run_page_shows_outcome_figures_objects_media_timeline_config(
        teacher_client: Any, course: Course, settings: Any, tmp_path: Path) -> None:
    from django.core.files.uploadedfile import SimpleUploadedFile

    settings.MEDIA_ROOT = tmp_path / "media"
    payload = robokit_payload(5)
    post(teacher_client, payload, course.kim_token)
    trace = (b'{"kind": "transition", "t": 0.0, "machine": "behaviour", "source_state": "CLEAR_VIEW", '
             b'"dest_state": "LOOK", "trigger": "view_clear"}\n'
             b'{"kind": "transition", "t": 2.5, "machine": "behaviour", "source_state": "LOOK", '
             b'"dest_state": "PICK_PLACE", "trigger": "found"}\n')
    files = {"run.mp4": mp4_head(), "xy.png": tiny_png(), "trace.jsonl": trace,
             "config.toml": b'[world]\nseed = 5\n'}
    data = {f"f{i}": SimpleUploadedFile(n, b) for i, (n, b) in enumerate(files.items())}
    resp = teacher_client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/", data=data,
                               HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert resp.status_code == 201
    html = teacher_client.get(f"/runs/{payload['run_id']}/").content.decode()
    assert "succeeded" in html and "sorted_total" in html and "detected_position" in html
    assert '<video id="video-1"' in html and "xy.png" in html
    assert "PICK_PLACE" in html and "view_clear" in html  # the state timeline from the trace
    assert "seed = 5" in html  # the config as uploaded
    video = [a for a in Result.objects.get().artifacts.all() if a.kind == "video"][0]
    ranged = teacher_client.get(f"/artifacts/{video.pk}/run.mp4", HTTP_RANGE="bytes=4-11")
    assert ranged.status_code == 206 and ranged.content == b"ftypisom"
    assert ranged["Content-Range"] == f"bytes 4-11/{len(mp4_head())}"


def test_student_page_with_token_shows_only_their_runs(client: Any, course: Course) -> None:
    post(client, robokit_payload(1, project="A"), course.kim_token)
    post(client, robokit_payload(2, project="B"), course.lee_token)
    post(client, {**LESSON_08, "student": "김민준"})  # unverified, under kim's name: not on kim's own page
    assert client.get("/me/").status_code == 200  # the token form
    bad = client.post("/me/", {"token": "rks_wrong"})
    assert bad.status_code == 401
    resp = client.post("/me/", {"token": course.kim_token})
    assert resp.status_code == 302
    html = client.get("/me/").content.decode()
    assert "김민준" in html and "000000000001" in html and "000000000002" not in html
    assert course.kim_token not in html
    assert client.get(f"/runs/{robokit_payload(1)['run_id']}/").status_code == 200
    assert client.get(f"/runs/{robokit_payload(2)['run_id']}/").status_code == 404  # lee's run
    assert client.get(f"/classes/{course.room.pk}/").status_code == 302  # not a teacher
    from robokit.server.tokens import revoke_student_tokens

    revoke_student_tokens(course.kim)
    assert "Paste the token" in client.get("/me/").content.decode()  # a revoked token ends the session


def test_csv_export_of_a_class(teacher_client: Any, course: Course) -> None:
    post(teacher_client, LESSON_08)
    post(teacher_client, {**LESSON_08, "student": "=HYPERLINK(\"http://x\")"})
    post(teacher_client, robokit_payload(3), course.kim_token)
    resp = teacher_client.get(f"/classes/{course.room.pk}/results.csv")
    assert resp.status_code == 200 and resp["Content-Type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO(resp.content.decode("utf-8-sig"))))
    assert len(rows) == 3
    assert rows[0]["student"] == "홍길동" and rows[0]["red_sorted"] == "2" and rows[0]["verified"] == "False"
    assert rows[1]["student"].startswith("'=")  # a formula is neutralised for spreadsheets
    assert rows[2]["student"] == "김민준" and rows[2]["outcome"] == "succeeded"


def test_tokens_never_appear_in_pages_or_logs(teacher_client: Any, course: Course,
                                              caplog: pytest.LogCaptureFixture) -> None:
    import logging

    caplog.set_level(logging.INFO)
    access = logging.getLogger("robokit.server.access")  # settings.LOGGING stops it propagating to the root
    access.addHandler(caplog.handler)
    try:
        _post_and_read_pages(teacher_client, course, caplog)
    finally:
        access.removeHandler(caplog.handler)


def _post_and_read_pages(teacher_client: Any, course: Course, caplog: pytest.LogCaptureFixture) -> None:
    post(teacher_client, robokit_payload(1), course.kim_token)
    post(teacher_client, LESSON_08, course.kim_token + "x")
    html = "".join(teacher_client.get(u).content.decode() for u in (
        "/", f"/classes/{course.room.pk}/", f"/runs/{robokit_payload(1)['run_id']}/",
        "/admin/course/token/", "/admin/course/student/"))
    for token in (course.kim_token, course.lee_token, course.teacher_token):
        assert token not in html
        assert token not in caplog.text
    assert "POST /api/robotics/result/ 201" in caplog.text and "POST /api/robotics/result/ 401" in caplog.text


def test_management_commands_make_a_class_students_and_tokens(db: Any, capsys: pytest.CaptureFixture[str],
                                                              monkeypatch: pytest.MonkeyPatch, settings: Any,
                                                              client: Any) -> None:
    from django.core.management import call_command

    settings.PASSWORD_HASHERS = ["django.contrib.auth.hashers.MD5PasswordHasher"]
    monkeypatch.setenv("ROBOKIT_TEACHER_PASSWORD", PASSWORD)
    call_command("create_teacher", "park")
    call_command("create_class", "2반", "--teacher", "park")
    call_command("add_students", "2반", "이서연", "최지우")
    out = capsys.readouterr().out
    tokens = dict(line.split("\t") for line in out.splitlines() if "\t" in line)
    assert set(tokens) == {"이서연", "최지우"} and all(t.startswith("rks_") for t in tokens.values())
    assert post(client, {**LESSON_08, "student": "x"}, tokens["이서연"]).json()["student"] == "이서연"
    assert post(client, LESSON_08).status_code == 401  # 2반 needs tokens
    call_command("revoke_token", "2반", "이서연")
    assert post(client, LESSON_08, tokens["이서연"]).status_code == 401
    call_command("teacher_token", "2반", "--teacher", "park")
    official = capsys.readouterr().out.strip().split("\t")[1]
    assert post(client, LESSON_08, official).json()["official"] is True
    assert client.login(username="park", password=PASSWORD)


def _robokit(*args: str, cwd: Path) -> Any:
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.slow
def test_cli_errors_are_one_line_and_help_does_not_import_django(tmp_path: Path) -> None:
    import socket
    import subprocess
    import sys

    code = ("import sys\nfrom robokit.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('django', 'waitress', 'requests') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stdout
    assert "serve" in out and out.strip().splitlines()[-1] == "[]"
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        proc = _robokit("serve", "--data", str(tmp_path / "srv"), "--port", str(busy.getsockname()[1]),
                        cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith("robokit: error: cannot listen on 127.0.0.1:") and "Traceback" not in proc.stderr
    bad = _robokit("manage", "--data", str(tmp_path / "srv"), "create_class", "x", "--teacher", "nobody",
                   cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.strip() == (
        "robokit: error: no teacher 'nobody': create one with `robokit serve --create-teacher NAME`")
    assert (tmp_path / "srv" / "db.sqlite3").is_file() and (tmp_path / "srv" / "secret_key").stat().st_mode & 0o077 == 0


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_robokit_manage_creates_a_private_data_folder_and_database(tmp_path: Path) -> None:
    import os
    import stat

    old = os.umask(0o022)  # the usual umask (inherited by the command): on its own it gives 0755 and 0644
    try:
        proc = _robokit("manage", "--data", str(tmp_path / "srv"), "migrate", cwd=tmp_path)
    finally:
        os.umask(old)
    assert proc.returncode == 0, proc.stderr
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in [tmp_path / "srv", *(tmp_path / "srv").iterdir()]}
    assert modes["srv"] == 0o700 and modes["db.sqlite3"] == 0o600 and modes["secret_key"] == 0o600
    assert all(mode & 0o077 == 0 for mode in modes.values()), modes  # -wal / -shm too, when present
    assert "readable by other users" not in proc.stderr  # made private: nothing to narrow, nothing said


def test_admin_issues_tokens_shown_once_and_revokes(admin_client: Any, course: Course) -> None:
    from robokit.server.models import Token
    from robokit.server.tokens import hash_token

    resp = admin_client.post("/admin/course/student/", {"action": "issue_tokens",
                                                        "_selected_action": [course.kim.pk]})
    assert resp.status_code == 200 and "no-store" in resp["Cache-Control"]
    html = resp.content.decode()
    token = html.split("<code>rks_", 1)[1].split("</code>", 1)[0]
    token = "rks_" + token
    assert Token.objects.filter(key_hash=hash_token(token), revoked_at__isnull=True, student=course.kim).exists()
    assert token not in admin_client.get("/admin/course/student/").content.decode()  # never again
    assert post(admin_client, LESSON_08, course.kim_token).status_code == 401  # the old one was replaced
    admin_client.post("/admin/course/student/", {"action": "revoke_tokens", "_selected_action": [course.kim.pk]})
    assert post(admin_client, LESSON_08, token).status_code == 401


def test_artifacts_are_served_only_to_who_may_see_the_run(client: Any, course: Course, settings: Any,
                                                          tmp_path: Path) -> None:
    from django.core.files.uploadedfile import SimpleUploadedFile

    settings.MEDIA_ROOT = tmp_path / "media"
    payload = robokit_payload(1)
    post(client, payload, course.kim_token)
    client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                data={"f": SimpleUploadedFile("xy.svg", b'<svg xmlns="http://www.w3.org/2000/svg"/>')},
                HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    url = f"/artifacts/{Result.objects.get().artifacts.get().pk}/xy.svg"
    assert client.get(url).status_code == 404  # nobody
    client.post("/me/", {"token": course.lee_token})
    assert client.get(url).status_code == 404  # another student
    client.post("/me/", {"token": course.kim_token})
    resp = client.get(url)
    assert resp.status_code == 200 and resp["Content-Type"] == "image/svg+xml"
    assert "sandbox" in resp["Content-Security-Policy"] and resp["X-Content-Type-Options"] == "nosniff"


def test_migrations_match_the_models() -> None:
    from django.core.management import call_command

    call_command("makemigrations", "course", "--check", "--dry-run", verbosity=0)  # exits 1 if a change is missing


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_robokit_manage_narrows_a_data_folder_and_database_left_open_by_an_earlier_version(tmp_path: Path) -> None:
    import os
    import stat

    data = tmp_path / "srv"
    data.mkdir()
    (data / "db.sqlite3").touch()  # an empty file is an empty SQLite database
    os.chmod(data, 0o755)
    os.chmod(data / "db.sqlite3", 0o644)
    proc = _robokit("manage", "--data", str(data), "migrate", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert stat.S_IMODE(data.stat().st_mode) == 0o700 and stat.S_IMODE((data / "db.sqlite3").stat().st_mode) == 0o600
    assert f"robokit: {data / 'db.sqlite3'} was readable by other users: now 0600" in proc.stderr
    assert f"robokit: data folder {data} was readable by other users: now 0700" in proc.stderr
