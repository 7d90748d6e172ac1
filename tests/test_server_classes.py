"""Projects and their rankings belong to a class: a teacher never sees or changes another teacher's.

Two teachers: ``teacher`` owns 1반 (the course fixture), ``park`` owns two classes of their own. Both classes post
project "A". Every way a ranking can change (the admin's change form, list edit, delete, a post that creates a
project) is tried by park against teacher's project; the admin's lists and filters are read for class names.
"""

from __future__ import annotations

import re
from typing import Any

import pytest
from course_helpers import PASSWORD, Course, post, robokit_payload

from robokit.server.models import Classroom, Project, Result

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db

PARK_CLASS, PARK_OTHER = "3반-park", "4반-park"


@pytest.fixture
def park(course: Course, client: Any) -> dict[str, Any]:
    """A second teacher with two classes and a student token in the first."""
    from django.contrib.auth import get_user_model
    from django.contrib.auth.models import Permission

    from robokit.server import tokens
    from robokit.server.models import Student

    user = get_user_model().objects.create_user("park", password=PASSWORD, is_staff=True)
    user.user_permissions.add(*Permission.objects.filter(content_type__app_label="course"))  # as create_teacher
    room = Classroom.objects.create(name=PARK_CLASS, owner=user)
    Classroom.objects.create(name=PARK_OTHER, owner=user)
    seo = Student.objects.create(classroom=room, name="서연")
    return {"user": user, "room": room, "token": tokens.issue_student_token(seo),
            "teacher_token": tokens.issue_teacher_token(room, user)}


def _login(client: Any, name: str) -> Any:
    client.logout()
    assert client.login(username=name, password=PASSWORD)
    return client


def _board_names(client: Any, room: Classroom, project: Project) -> list[str]:
    """The students' table of a leaderboard, in order (names as the page writes them)."""
    html = client.get(f"/classes/{room.pk}/projects/{project.pk}/").content.decode()
    section = html[html.index('id="students"'):]
    section = section[:section.index("</table>")]
    cells = [cell.split("</td>", 1)[0] for cell in section.split('<td class="student">')[1:]]
    return [re.sub(r"<[^>]+>", "", cell) for cell in cells]


def _two_boards(client: Any, course: Course, park: dict[str, Any]) -> tuple[Project, Project]:
    # kim: 4 sorted in 9 s; lee: 2 sorted in 5 s. By sorted count kim leads; by time lee does.
    post(client, robokit_payload(1, red_sorted=2, blue_sorted=2, failures=0, total_time=9.0), course.kim_token)
    post(client, robokit_payload(2, red_sorted=1, blue_sorted=1, failures=0, total_time=5.0), course.lee_token)
    post(client, robokit_payload(3, red_sorted=1, blue_sorted=0, failures=0, total_time=4.0), park["token"])
    return Project.objects.get(classroom=course.room, name="A"), Project.objects.get(classroom=park["room"], name="A")


def test_each_class_has_its_own_project_a_and_ranking(client: Any, course: Course, park: dict[str, Any]) -> None:
    mine, theirs = _two_boards(client, course, park)
    assert mine.pk != theirs.pk
    assert {r.classroom_id for r in mine.results.all()} == {course.room.pk}
    assert [r.classroom_id for r in theirs.results.all()] == [park["room"].pk]
    assert mine.ranking == theirs.ranking == "-sorted_total,failures,total_time"  # the default of a sort run


def test_second_teacher_cannot_change_the_first_teachers_ranking(client: Any, course: Course,
                                                                 park: dict[str, Any]) -> None:
    mine, theirs = _two_boards(client, course, park)
    teacher = _login(client, "teacher")
    before = _board_names(teacher, course.room, mine)
    assert before == ["김민준", "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;"]  # 4 sorted beats 2

    c = _login(client, "park")
    form = {"classroom": park["room"].pk, "name": "A", "ranking": "total_time"}
    assert c.post(f"/admin/course/project/{mine.pk}/change/", form).status_code == 404
    assert c.get(f"/admin/course/project/{mine.pk}/change/").status_code == 404
    assert c.post(f"/admin/course/project/{mine.pk}/delete/", {"post": "yes"}).status_code == 404
    assert c.get(f"/admin/course/project/{mine.pk}/history/").status_code == 404
    assert c.post(f"/admin/course/project/{mine.pk}/change/",  # moving it into park's class: still not theirs
                  {**form, "classroom": course.room.pk}).status_code == 404
    bulk = c.post("/admin/course/project/", {"action": "delete_selected", "_selected_action": [mine.pk],
                                             "post": "yes"})
    assert bulk.status_code in (200, 302)
    mine.refresh_from_db()
    assert mine.ranking == "-sorted_total,failures,total_time" and mine.classroom == course.room
    # park's own project: the change goes through, and only park's board follows it.
    ok = c.post(f"/admin/course/project/{theirs.pk}/change/", {**form, "ranking": "total_time"})
    assert ok.status_code == 302
    theirs.refresh_from_db()
    assert theirs.ranking == "total_time"
    assert _board_names(_login(client, "teacher"), course.room, mine) == before
    assert _login(client, "park").get(f"/classes/{course.room.pk}/projects/{mine.pk}/").status_code == 404


def test_a_leaderboard_url_never_mixes_one_class_with_anothers_project(client: Any, course: Course,
                                                                       park: dict[str, Any]) -> None:
    mine, theirs = _two_boards(client, course, park)
    c = _login(client, "park")
    assert c.get(f"/classes/{park['room'].pk}/projects/{theirs.pk}/").status_code == 200
    assert c.get(f"/classes/{course.room.pk}/projects/{mine.pk}/").status_code == 404
    assert c.get(f"/classes/{park['room'].pk}/projects/{mine.pk}/").status_code == 404


def test_posting_project_a_in_another_class_never_touches_this_class(client: Any, course: Course,
                                                                      park: dict[str, Any]) -> None:
    post(client, robokit_payload(1), course.kim_token)
    mine = Project.objects.get(classroom=course.room, name="A")
    mine.ranking = "total_time"
    mine.save()
    collect = {"student": "x", "project": "A", "collected": 3, "total_time": 4.0}
    assert post(client, collect, park["teacher_token"]).status_code == 201
    mine.refresh_from_db()
    assert mine.ranking == "total_time" and mine.results.count() == 1
    assert Project.objects.get(classroom=park["room"], name="A").ranking == "-collected,total_time"


def test_admin_lists_and_filters_show_only_the_teachers_own_class_names(client: Any, course: Course,
                                                                        park: dict[str, Any]) -> None:
    _two_boards(client, course, park)
    post(client, robokit_payload(4), park["teacher_token"])
    seo_project = Project.objects.create(classroom=Classroom.objects.get(name=PARK_OTHER), name="B")
    Result.objects.create(run_id="r-other", classroom=seo_project.classroom, project=seo_project,
                          student_name="x")
    c = _login(client, "park")
    for model in ("classroom", "student", "token", "project", "result"):
        html = c.get(f"/admin/course/{model}/").content.decode()
        assert "1반" not in html, model
        assert PARK_CLASS in html, model
    for model in ("project", "result"):  # two classes with rows: the class filter is shown, with only park's
        html = c.get(f"/admin/course/{model}/").content.decode()
        filters = html[html.index('id="changelist-filter"'):]
        assert PARK_CLASS in filters and PARK_OTHER in filters and "1반" not in filters, model
    add = c.get("/admin/course/project/add/").content.decode()
    assert PARK_CLASS in add and "1반" not in add  # the class choices of a new project
    from django.contrib.auth import get_user_model

    get_user_model().objects.create_superuser("root", password=PASSWORD)
    every = _login(client, "root").get("/admin/course/project/").content.decode()
    assert "1반" in every and PARK_CLASS in every  # a superuser sees every class


def test_deleting_a_class_removes_its_projects_and_results(client: Any, course: Course,
                                                           park: dict[str, Any]) -> None:
    _two_boards(client, course, park)
    course.room.delete()
    assert list(Project.objects.values_list("classroom__name", flat=True)) == [PARK_CLASS]
    assert Result.objects.count() == 1
    from django.db.models import RestrictedError

    with pytest.raises(RestrictedError):  # a project with runs is not deleted on its own
        Project.objects.get().delete()


@pytest.mark.slow  # migrates a database from scratch: the slow tier
@pytest.mark.django_db(transaction=True)
def test_migration_gives_each_class_its_own_copy_of_a_shared_project() -> None:
    from django.db import connection
    from django.db.migrations.executor import MigrationExecutor

    executor = MigrationExecutor(connection)
    latest = executor.loader.graph.leaf_nodes("course")
    executor.migrate([("course", "0001_initial")])
    try:
        old = MigrationExecutor(connection).loader.project_state([("course", "0001_initial")]).apps
        user = old.get_model("auth", "User").objects.create(username="t")
        room1 = old.get_model("course", "Classroom").objects.create(name="1반", owner_id=user.pk)
        room3 = old.get_model("course", "Classroom").objects.create(name="3반", owner_id=user.pk)
        project = old.get_model("course", "Project")
        shared = project.objects.create(name="A", ranking="total_time")
        project.objects.create(name="unused", ranking="x")
        result = old.get_model("course", "Result")
        for run_id, room in (("r1", room1), ("r2", room1), ("r3", room3)):
            result.objects.create(run_id=run_id, classroom_id=room.pk, project_id=shared.pk, student_name="s")

        executor = MigrationExecutor(connection)
        executor.migrate(latest)
        rows = {(p.classroom.name, p.name, p.ranking): sorted(p.results.values_list("run_id", flat=True))
                for p in Project.objects.select_related("classroom")}
        assert rows == {("1반", "A", "total_time"): ["r1", "r2"], ("3반", "A", "total_time"): ["r3"]}

        executor = MigrationExecutor(connection)
        executor.migrate([("course", "0001_initial")])  # and back: one "A" with every run again
        back = MigrationExecutor(connection).loader.project_state([("course", "0001_initial")]).apps
        projects = back.get_model("course", "Project").objects.all()
        assert [(p.name, p.ranking) for p in projects] == [("A", "total_time")]
        assert back.get_model("course", "Result").objects.filter(project=projects[0]).count() == 3
    finally:
        MigrationExecutor(connection).migrate(latest)
