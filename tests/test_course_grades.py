"""Grades (one CSV row per student, a column group per assignment) and moderation (exclude a run or a submission
with a reason, kept in the audit log; boards and grades leave it out)."""

from __future__ import annotations

import csv
import datetime as dt
import io
from typing import Any

import pytest
from course_helpers import PASSWORD, Course, post, robokit_payload
from course_work import OFFICIAL, make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
T0 = dt.datetime(2026, 11, 20, 9, 0, tzinfo=dt.timezone.utc)


def evaluated(a: Any, student: Any, ok: int, n: int, minutes: int, late: bool = False) -> Any:
    """A submission as the queue leaves it (figures set by hand: grades read them, they do not compute them)."""
    from robokit.server.models import Submission

    sub = Submission.objects.create(assignment=a, student=student, config_text=OFFICIAL, late=late,
                                    status="done", trials=n, succeeded=ok, success_rate=ok / n,
                                    wilson_low=ok / n / 2, wilson_high=min(1.0, ok / n + 0.1))
    Submission.objects.filter(pk=sub.pk).update(submitted_at=T0 + dt.timedelta(minutes=minutes))
    sub.refresh_from_db()
    return sub


def grades(client: Any, course: Course) -> list[dict[str, str]]:
    resp = client.get(f"/classes/{course.room.pk}/grades.csv")
    assert resp.status_code == 200 and resp["Content-Type"].startswith("text/csv")
    text = resp.content.decode("utf-8")
    assert text.startswith("\ufeff")
    return list(csv.DictReader(io.StringIO(text[1:])))


def test_grades_one_row_per_student_with_the_best_official_result(client: Any, course: Course) -> None:
    a1 = make_assignment(course.room, "A1", due_at=T0 + dt.timedelta(hours=1))
    a2 = make_assignment(course.room, "A2", due_at=T0 + dt.timedelta(days=7))
    evaluated(a1, course.kim, 12, 20, 5)
    best = evaluated(a1, course.kim, 18, 20, 30)
    evaluated(a1, course.kim, 15, 20, 50)
    evaluated(a1, course.lee, 20, 20, 90, late=True)
    client.login(username="teacher", password=PASSWORD)
    rows = grades(client, course)
    assert [r["student"] for r in rows] == sorted([course.kim.name, course.lee.name])  # one row each
    kim = next(r for r in rows if r["student"] == "김민준")
    assert kim["A1: success_rate"] == "0.9000" and kim["A1: submissions"] == "3"
    assert kim["A1: submitted_at"] == best.submitted_at.isoformat() and kim["A1: late"] == ""
    assert kim["A2: success_rate"] == "" and kim["A2: submissions"] == "0"
    lee = next(r for r in rows if r["student"] != "김민준")
    assert lee["A1: success_rate"] == "1.0000" and lee["A1: late"] == "late"
    assert a2.name == "A2"


def test_grades_workbook_has_the_csv_rows_with_numbers_and_times_read_back_by_openpyxl(client: Any,
                                                                                      course: Course) -> None:
    from openpyxl import load_workbook

    from robokit.server.models import Student

    a1 = make_assignment(course.room, "A1", due_at=T0 + dt.timedelta(hours=1))
    make_assignment(course.room, "A2", due_at=T0 + dt.timedelta(days=7))
    evaluated(a1, course.kim, 12, 20, 5)
    best = evaluated(a1, course.kim, 18, 20, 30)
    evaluated(a1, course.lee, 20, 20, 90, late=True)
    Student.objects.create(classroom=course.room, name="=1+1")  # a name a spreadsheet would run
    client.login(username="teacher", password=PASSWORD)
    resp = client.get(f"/classes/{course.room.pk}/grades.xlsx")
    assert resp.status_code == 200 and resp["Content-Type"].startswith("application/vnd.openxmlformats")
    assert resp["Content-Disposition"] == f'attachment; filename="grades-class-{course.room.pk}.xlsx"'
    sheet = load_workbook(io.BytesIO(resp.content)).active
    rows = [[c.value for c in row] for row in sheet.iter_rows()]
    groups = ("success_rate", "wilson_low", "wilson_high", "submitted_at", "late", "submissions")
    assert rows[0] == ["student", *[f"{a}: {c}" for a in ("A1", "A2") for c in groups]]
    by_name = {row[0]: dict(zip(rows[0], row, strict=True)) for row in rows[1:]}
    assert sorted(by_name) == sorted(["김민준", course.lee.name, "=1+1"])  # one row per student
    kim = by_name["김민준"]
    assert kim["A1: success_rate"] == 0.9 and kim["A1: wilson_low"] == 0.45 and kim["A1: submissions"] == 2
    assert kim["A1: submitted_at"] == (T0 + dt.timedelta(minutes=30)).replace(tzinfo=None)  # UTC, as a time
    assert kim["A1: submitted_at"] == best.submitted_at.replace(tzinfo=None) and kim["A1: late"] is None
    assert kim["A2: success_rate"] is None and kim["A2: submissions"] == 0
    lee = by_name[course.lee.name]
    assert lee["A1: success_rate"] == 1.0 and lee["A1: late"] == "late"
    formula_row = next(row for row in sheet.iter_rows(min_row=2) if row[0].value == "=1+1")
    assert formula_row[0].data_type == "s"  # text, not a formula
    csv_names = [r["student"] for r in grades(client, course)]  # the CSV's rows, its "=1+1" quoted as "'=1+1"
    assert csv_names == [("'" if row[0] == "=1+1" else "") + row[0] for row in rows[1:]]


def test_excluding_a_submission_removes_it_from_board_and_grades_with_an_audit_entry(client: Any,
                                                                                      course: Course) -> None:
    from robokit.server.models import ModerationEvent

    a = make_assignment(course.room, "A1")
    evaluated(a, course.kim, 10, 20, 5)
    top = evaluated(a, course.kim, 19, 20, 10)
    client.login(username="teacher", password=PASSWORD)
    board = client.get(f"/classes/{course.room.pk}/assignments/{a.pk}/").content.decode()
    assert "0.95" in board
    no_reason = client.post(f"/classes/{course.room.pk}/moderate/", {"submission": top.pk, "reason": " "})
    assert no_reason.status_code == 400
    resp = client.post(f"/classes/{course.room.pk}/moderate/",
                       {"submission": top.pk, "action": "exclude", "reason": "copied 이서연's config"})
    assert resp.status_code == 302
    board = client.get(f"/classes/{course.room.pk}/assignments/{a.pk}/").content.decode()
    assert "0.95" not in board and "0.50" in board
    assert next(r for r in grades(client, course) if r["student"] == "김민준")["A1: success_rate"] == "0.5000"
    event = ModerationEvent.objects.get()
    assert (event.action, event.reason, event.teacher, event.submission) == ("exclude", "copied 이서연's config",
                                                                              course.teacher, top)
    log = client.get(f"/classes/{course.room.pk}/moderation/").content.decode()
    assert "copied 이서연&#x27;s config" in log
    client.post(f"/classes/{course.room.pk}/moderate/",
                {"submission": top.pk, "action": "include", "reason": "explained in class"})
    assert next(r for r in grades(client, course) if r["student"] == "김민준")["A1: success_rate"] == "0.9500"
    assert ModerationEvent.objects.count() == 2


def test_excluding_a_run_removes_it_from_the_project_leaderboard(client: Any, course: Course) -> None:
    from robokit.server.models import Result

    post(client, robokit_payload(1, project="A"), course.kim_token)
    run = Result.objects.get()
    client.login(username="teacher", password=PASSWORD)
    url = f"/classes/{course.room.pk}/projects/{run.project.pk}/"
    assert "김민준" in client.get(url).content.decode()
    resp = client.post(f"/classes/{course.room.pk}/moderate/", {"run_id": run.run_id, "reason": "test run"})
    assert resp.status_code == 302 and resp["Location"] == f"/runs/{run.run_id}/"
    assert "김민준" not in client.get(url).content.decode()
    assert "excluded from the boards" in client.get(f"/runs/{run.run_id}/").content.decode()


def test_another_teacher_can_neither_see_nor_moderate(client: Any, course: Course) -> None:
    from django.contrib.auth import get_user_model

    a = make_assignment(course.room, "A1")
    sub = evaluated(a, course.kim, 1, 2, 1)
    get_user_model().objects.create_user("other", password=PASSWORD)
    client.login(username="other", password=PASSWORD)
    room = course.room.pk
    for url in (f"/classes/{room}/grades.csv", f"/classes/{room}/assignments/{a.pk}/", f"/submissions/{sub.pk}/",
                f"/classes/{room}/moderation/", f"/classes/{room}/students/{course.kim.pk}/dashboard/",
                f"/classes/{room}/assignments/{a.pk}/distribution.svg"):
        assert client.get(url).status_code == 404, url
    assert client.post(f"/classes/{room}/moderate/", {"submission": sub.pk, "reason": "x"}).status_code == 404
    sub.refresh_from_db()
    assert not sub.excluded


def test_an_assignment_made_in_the_admin_gets_its_project(client: Any, course: Course) -> None:
    from django.contrib.auth.models import Permission

    from robokit.server.models import Assignment

    course.teacher.user_permissions.add(*Permission.objects.filter(content_type__app_label="course"))
    client.login(username="teacher", password=PASSWORD)
    resp = client.post("/admin/course/assignment/add/", {
        "classroom": course.room.pk, "name": "admin-made", "kind": "drop_test", "config_text": OFFICIAL,
        "allowed_keys": '["behaviour.duration"]', "seeds": "[0, 1, 2]", "ranking": "-success_rate",
        "trial_seconds": "30", "late_policy": "accept", "max_waiting": "1", "max_per_day": "10"})
    assert resp.status_code == 302, resp.content.decode()[:3000]
    a = Assignment.objects.get(name="admin-made")
    assert a.project.name == "admin-made" and a.project.classroom == course.room and a.seeds == [0, 1, 2]
    bad = client.post(f"/admin/course/assignment/{a.pk}/change/", {
        "classroom": course.room.pk, "name": "admin-made", "config_text": OFFICIAL.replace("duration = 0.5",
                                                                                          "duration = -2"),
        "allowed_keys": "[]", "seeds": "[0]", "ranking": "-success_rate", "trial_seconds": "30",
        "late_policy": "accept", "max_waiting": "1", "max_per_day": "10"})
    assert bad.status_code == 200 and "behaviour.duration: input should be greater than 0" in bad.content.decode()


def test_a_teacher_from_before_the_upgrade_gets_the_new_models_permissions(course: Course) -> None:
    from django.contrib.auth.models import Permission
    from django.core.management import call_command

    old = Permission.objects.filter(content_type__app_label="course", content_type__model__in=[
        "classroom", "student", "token", "project", "result", "artifact"])
    course.teacher.user_permissions.set(old)  # what create_teacher gave before assignments existed
    call_command("migrate", verbosity=0)  # robokit serve / manage migrate on every start
    course.teacher = type(course.teacher).objects.get(pk=course.teacher.pk)  # permissions are cached per object
    assert course.teacher.has_perm("course.change_assignment") and course.teacher.has_perm("course.view_submission")
