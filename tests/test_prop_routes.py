"""Every page and API route of the course server against every role, the matrix generated from the URL configuration.

The routes come from Django's resolver (``get_resolver().url_patterns``), so a route added tomorrow is requested by
this test the day it is added -- and fails it until the table below says who may use it. The roles: the student who
owns the objects (``student``), a student of the same class (``classmate``), a student of another class
(``stranger``), the class's teacher, another teacher, and anonymous. Each role carries its credentials the way the
server takes them: a student's session opened at ``/me/`` with their token and the token as ``Authorization``; a
teacher logged in and holding the class's teacher token (the other teacher: their own class's).

The expected answer is the rule table of docs/server.md, written out plainly: teacher pages answer the class's
teacher and 404 another teacher (a student, not logged in, is sent to the login page); a run and its files are the
teacher's and the student's who posted it; the API takes tokens as its table says.
"""

from __future__ import annotations

import json
from typing import Any

import pytest
from course_helpers import robokit_payload, tiny_png

pytest_plugins = ["course_fixtures"]

ROLES = ("student", "classmate", "stranger", "teacher", "other_teacher", "anonymous")
STUDENTS = ("student", "classmate", "stranger")
LOGIN = "login"  # a redirect to the teacher's login page
ADMIN_LOGIN = "admin-login"  # a redirect to the admin's login page


def every(answer: Any) -> dict[str, Any]:
    return dict.fromkeys(ROLES, answer)


def teacher_only(ok: int = 200) -> dict[str, Any]:
    """A teacher's page of the class: its teacher, 404 for another teacher (no hint the class exists), login for
    everyone not logged in (students included: a student's session is not a teacher's login)."""
    return {**every(LOGIN), "teacher": ok, "other_teacher": 404}


# route name -> (method, role -> status code or LOGIN), from docs/server.md
RULES: dict[str, tuple[str, dict[str, Any]]] = {
    "home": ("GET", {**every(200), **dict.fromkeys(STUDENTS, 302)}),  # a student's session goes on to /me/
    "login": ("GET", every(200)),
    "logout": ("POST", every(302)),
    "me": ("GET", every(200)),
    "me-logout": ("POST", every(302)),
    "replay-viewer": ("GET", every(200)),
    "replay-script": ("GET", every(200)),
    "my-training-chart": ("GET", {**every(404), **dict.fromkeys(STUDENTS, 200)}),  # the session's own chart
    "classroom": ("GET", teacher_only()),
    "leaderboard": ("GET", teacher_only()),
    "history": ("GET", teacher_only()),
    "export-csv": ("GET", teacher_only()),
    "assignment": ("GET", teacher_only()),
    "assignment-chart": ("GET", teacher_only()),
    "dashboard": ("GET", teacher_only()),
    "student-chart": ("GET", teacher_only()),
    "moderation": ("GET", teacher_only()),
    "moderate": ("POST", teacher_only(400)),  # the class's teacher gets past the door: 400, a reason is required
    "submission": ("GET", teacher_only()),
    "reevaluate": ("POST", teacher_only(400)),  # as moderate: a reason is required
    "grades-csv": ("GET", teacher_only()),
    "grades-xlsx": ("GET", teacher_only()),
    # the student's own verified run: its teacher and the student; anonymous is asked to log in
    "run": ("GET", {**every(404), "student": 200, "teacher": 200, "anonymous": LOGIN}),
    "artifact": ("GET", {**every(404), "student": 200, "teacher": 200}),
    # a submission's state: its student's token or the class's teacher token
    "api-submission": ("GET", {**every(404), "student": 200, "teacher": 200}),
    # the student's run id posted again: its owner gets the first record, anyone else 409
    "api-result": ("POST", {**every(409), "student": 200}),
    # files for the student's verified run: whoever posted it or the class's teacher token; 403 another token,
    # 401 none
    "api-artifacts": ("POST", {**every(403), "student": 201, "teacher": 201, "anonymous": 401}),
    # an empty submission: a student of the class gets past the door (400 naming `config`); a student of another
    # class does not find the assignment (404); a teacher's token 403; no token 401
    "api-submit": ("POST", {"student": 400, "classmate": 400, "stranger": 404, "teacher": 403, "other_teacher": 403,
                            "anonymous": 401}),
    "api-training": ("POST", {**dict.fromkeys(STUDENTS, 400), "teacher": 403, "other_teacher": 403,
                              "anonymous": 401}),
    "admin": ("GET", {**every(ADMIN_LOGIN), "teacher": 200, "other_teacher": 200}),  # staff only
}


def routes() -> list[tuple[str, str]]:
    """(name, example URL) of every route in the URL configuration; an include (the admin) by its namespace."""
    from django.urls import get_resolver
    from django.urls.resolvers import URLPattern, URLResolver

    out = []
    for p in get_resolver().url_patterns:
        if isinstance(p, URLPattern):
            out.append((p.name, str(p.pattern)))
        elif isinstance(p, URLResolver):
            out.append((p.namespace or str(p.pattern), str(p.pattern)))
    return out


@pytest.fixture
def world(course: Any, settings: Any, tmp_path: Any, client: Any) -> dict[str, Any]:
    """Two classes, their teachers, three students, a run with a file, an assignment with a submission."""
    from course_work import OFFICIAL, make_assignment
    from django.contrib.auth import get_user_model

    from robokit.server import tokens
    from robokit.server.models import Classroom, Project, Student, Submission

    settings.MEDIA_ROOT = tmp_path / "media"
    other = get_user_model().objects.create_user("other-teacher", password="x", is_staff=True)
    room_b = Classroom.objects.create(name="2반", owner=other)
    park = Student.objects.create(classroom=room_b, name="박지호")
    tok = {"student": course.kim_token, "classmate": course.lee_token,
           "stranger": tokens.issue_student_token(park), "teacher": course.teacher_token,
           "other_teacher": tokens.issue_teacher_token(room_b, other), "anonymous": None}
    payload = robokit_payload(7)
    posted = client.post("/api/robotics/result/", data=json.dumps(payload), content_type="application/json",
                         HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert posted.status_code == 201, posted.content
    up = client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                     data={"f": _upload("plot.png", tiny_png())}, HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert up.status_code == 201, up.content
    artifact = up.json()["artifacts"][0]
    assignment = make_assignment(course.room)
    sub = Submission.objects.create(assignment=assignment, student=course.kim, config_text=OFFICIAL)
    project = Project.objects.get(classroom=course.room, name="A")
    return {"tokens": tok, "payload": payload, "users": {"teacher": course.teacher, "other_teacher": other},
            "other_class": room_b.pk,
            "args": {"pk": course.room.pk, "project_pk": project.pk, "student_pk": course.kim.pk,
                     "spk": course.kim.pk, "apk": assignment.pk, "run_id": payload["run_id"],
                     "name": assignment.name},
            "by_route": {"artifact": {"pk": int(artifact["url"].split("/")[2]), "name": artifact["name"]},
                         "submission": {"pk": sub.pk}, "reevaluate": {"pk": sub.pk}, "api-submission": {"pk": sub.pk},
                         "assignment-chart": {"kind": "reasons"}, "student-chart": {"kind": "weekly"}}}


def _upload(name: str, content: bytes) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    return SimpleUploadedFile(name, content)


def _url(name: str, pattern: str, world: dict[str, Any]) -> str:
    from django.urls import reverse
    from django.urls.resolvers import RoutePattern

    if name == "admin":
        return "/admin/"
    params = RoutePattern(pattern).converters.keys()
    values = {**world["args"], **world["by_route"].get(name, {})}
    missing = [p for p in params if p not in values]
    assert not missing, f"route {name!r} ({pattern}) takes {missing}: give this test a value for them"
    return reverse(name, kwargs={p: values[p] for p in params})


def _client(role: str, world: dict[str, Any]) -> Any:
    from django.test import Client

    c = Client(enforce_csrf_checks=False)
    if role in world["users"]:
        c.force_login(world["users"][role])
    elif role in STUDENTS:
        opened = c.post("/me/", {"token": world["tokens"][role]})
        assert opened.status_code in (200, 302), opened.status_code
    return c


def _request(c: Any, role: str, name: str, method: str, url: str, world: dict[str, Any]) -> Any:
    token = world["tokens"][role]
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    if method == "GET":
        return c.get(url, **headers)
    if name == "api-result":
        return c.post(url, data=json.dumps(world["payload"]), content_type="application/json", **headers)
    if name == "api-artifacts":  # a file of this role's own: no two roles send the same bytes
        png = tiny_png(width=2 + ROLES.index(role))
        return c.post(url, data={"f": _upload(f"{role}.png", png)}, **headers)
    if name.startswith("api-"):
        return c.post(url, data="{}", content_type="application/json", **headers)
    return c.post(url, {}, **headers)


def _answer(resp: Any) -> Any:
    if resp.status_code == 302 and resp["Location"].startswith("/accounts/login/"):
        return LOGIN
    if resp.status_code == 302 and resp["Location"].startswith("/admin/login/"):
        return ADMIN_LOGIN
    return resp.status_code


def test_every_route_answers_every_role_as_the_rules_say(world: dict[str, Any]) -> None:
    found = routes()
    unruled = sorted({name for name, _ in found} - set(RULES))
    assert not unruled, f"routes with no access rule in this test: {unruled} (add each to RULES)"
    assert {name for name, _ in found} == set(RULES), "RULES names a route the server no longer has"
    wrong = []
    for role in ROLES:
        c = _client(role, world)
        for name, pattern in found:
            if name in ("logout", "me-logout"):
                continue  # they end the session: asked last, below
            method, expected = RULES[name]
            got = _answer(_request(c, role, name, method, _url(name, pattern, world), world))
            if got != expected[role]:
                wrong.append(f"{role} {method} {name}: {got}, expected {expected[role]}")
        for name in ("me-logout", "logout"):
            method, expected = RULES[name]
            got = _answer(_request(c, role, name, method, _url(name, "", world), world))
            if got != expected[role]:
                wrong.append(f"{role} {method} {name}: {got}, expected {expected[role]}")
    assert not wrong, "\n".join(wrong)


# one credential at a time: a page goes by the session (a student's opened at /me/, a teacher's login), the API by
# the Authorization token; with only the other one a role is anonymous there
SPLIT = {"student-session": ("student", "session"), "student-token": ("student", "token"),
         "teacher-login": ("teacher", "session"), "teacher-token": ("teacher", "token")}


def _split_answer(variant: str, name: str) -> Any:
    role, holds = SPLIT[variant]
    api = name.startswith("api-")
    return RULES[name][1][role if (holds == "token") == api else "anonymous"]


def test_every_route_takes_only_its_own_kind_of_credential(world: dict[str, Any]) -> None:
    """A page is not opened by an ``Authorization`` token, nor the API by a session or a teacher's login: each
    route against the owning student and the class's teacher holding one credential only."""
    wrong = []
    found = [(n, p) for n, p in routes() if n not in ("logout", "me-logout")]
    for variant, (role, holds) in SPLIT.items():
        c = _client(role, world) if holds == "session" else _client("anonymous", world)
        token = world["tokens"][role] if holds == "token" else None
        for name, pattern in found:
            method = RULES[name][0]
            url = _url(name, pattern, world)
            headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
            if method == "GET":
                resp = c.get(url, **headers)
            elif name == "api-result":
                resp = c.post(url, data=json.dumps(world["payload"]), content_type="application/json", **headers)
            elif name == "api-artifacts":  # bytes no other request sent
                png = tiny_png(width=10 + list(SPLIT).index(variant))
                resp = c.post(url, data={"f": _upload(f"{variant}.png", png)}, **headers)
            elif name.startswith("api-"):
                resp = c.post(url, data="{}", content_type="application/json", **headers)
            else:
                resp = c.post(url, {}, **headers)
            got, expected = _answer(resp), _split_answer(variant, name)
            if got != expected:
                wrong.append(f"{variant} {method} {name}: {got}, expected {expected}")
    assert not wrong, "\n".join(wrong)


def test_a_session_ended_or_a_token_revoked_takes_the_students_access_away(world: dict[str, Any]) -> None:
    """After ``/me/logout/`` (or with the token revoked) the student's session is anonymous again on every route
    that only the session opened: the run, its file and the training chart."""
    from robokit.server.models import Token

    gated = ("run", "artifact", "my-training-chart")
    c = _client("student", world)
    urls = {n: _url(n, p, world) for n, p in routes() if n in gated}
    assert all(c.get(u).status_code == 200 for u in urls.values())
    c.post("/me/logout/")
    after = {n: _answer(c.get(u)) for n, u in urls.items()}
    assert after == {n: RULES[n][1]["anonymous"] for n in gated}
    c = _client("student", world)
    Token.objects.filter(kind=Token.STUDENT, student__name="김민준").update(revoked_at="2026-01-01T00:00:00Z")
    revoked = {n: _answer(c.get(u)) for n, u in urls.items()}
    assert revoked == {n: RULES[n][1]["anonymous"] for n in gated}


def test_another_teacher_naming_their_own_class_finds_none_of_this_class_objects(world: dict[str, Any]) -> None:
    """Every route whose URL names a class and an object in it (a project, a student, an assignment): another
    teacher putting their own class in the URL, with this class's object, gets 404 -- the object is looked up in
    the class named, not anywhere."""
    from django.urls import reverse
    from django.urls.resolvers import RoutePattern

    c = _client("other_teacher", world)
    wrong, tried = [], 0
    for name, pattern in routes():
        params = list(RoutePattern(pattern).converters) if name != "admin" else []
        if "pk" not in params or len(params) < 2 or name.startswith("api-"):
            continue
        values = {**world["args"], **world["by_route"].get(name, {}), "pk": world["other_class"]}
        url = reverse(name, kwargs={p: values[p] for p in params})
        got = _answer(_request(c, "other_teacher", name, RULES[name][0], url, world))
        tried += 1
        if got != 404:
            wrong.append(f"other_teacher {name} {url}: {got}, expected 404")
    assert tried >= 6 and not wrong, "\n".join(wrong)


@pytest.fixture
def twin(world: dict[str, Any], course: Any) -> dict[str, Any]:
    """The class's teacher owns a second class, with a student, a run and a submission of its own, and holds that
    class's teacher token too."""
    from course_work import OFFICIAL, make_assignment

    from robokit.server import tokens
    from robokit.server.models import Classroom, Result, Student, Submission

    room_c = Classroom.objects.create(name="3반", owner=course.teacher)
    choi = Student.objects.create(classroom=room_c, name="최서윤")
    run = Result.objects.create(classroom=room_c, project=course.room.projects.first(), student=choi,
                                student_name=choi.name, run_id="c-run-1", outcome="succeeded", payload={},
                                verified=True)
    sub = Submission.objects.create(assignment=make_assignment(room_c), student=choi, config_text=OFFICIAL)
    return {"room": room_c, "student": choi, "run": run, "submission": sub,
            "token": tokens.issue_teacher_token(room_c, course.teacher)}


def test_a_teacher_of_two_classes_reaches_each_class_objects_only_under_that_class(world: dict[str, Any],
                                                                                   course: Any,
                                                                                   twin: dict[str, Any]) -> None:
    """The same teacher, logged in, owns both classes: a URL naming their other class with this class's object (a
    project, a student, an assignment) is 404, the other class's pages and exports name none of this class's
    students, and moderating this class's run or submission through the other class's URL changes nothing. Holding
    the other class's teacher token, every API route answers as to another teacher: a teacher token is a class's."""
    from django.urls import reverse
    from django.urls.resolvers import RoutePattern

    from robokit.server.models import ModerationEvent, Result, Submission

    c = _client("teacher", world)
    wrong = []
    for name, pattern in routes():
        params = list(RoutePattern(pattern).converters) if name != "admin" else []
        if "pk" not in params or name.startswith("api-") or name in ("artifact", "submission", "reevaluate"):
            continue
        values = {**world["args"], **world["by_route"].get(name, {}), "pk": twin["room"].pk}
        url = reverse(name, kwargs={p: values[p] for p in params})
        resp = _request(c, "teacher", name, RULES[name][0], url, world)
        if len(params) > 1:
            if resp.status_code != 404:
                wrong.append(f"{name} {url}: {_answer(resp)}, expected 404")
        elif name != "moderate":
            body = b"".join(resp.streaming_content) if resp.streaming else resp.content
            if resp.status_code != 200 or "김민준".encode() in body:
                wrong.append(f"{name} {url}: {resp.status_code}, names this class's student")
            if name in ("classroom", "grades-csv") and twin["student"].name.encode() not in body:
                wrong.append(f"{name} {url}: its own student missing")
    a_run = Result.objects.get(run_id=world["payload"]["run_id"])
    a_sub = Submission.objects.get(pk=world["by_route"]["submission"]["pk"])
    for field, value in (("run_id", a_run.run_id), ("submission", a_sub.pk)):
        resp = c.post(reverse("moderate", kwargs={"pk": twin["room"].pk}), {"reason": "copied", field: value})
        if resp.status_code != 404:
            wrong.append(f"moderate {field} of this class through the other class: {resp.status_code}")
    a_run.refresh_from_db()
    a_sub.refresh_from_db()
    assert not a_run.excluded and not a_sub.excluded and not ModerationEvent.objects.exists()

    # a student of the other class submits to the assignment name both classes use: it is their class's
    from course_work import OFFICIAL
    from django.test import override_settings

    from robokit.server import tokens

    choi = tokens.issue_student_token(twin["student"])
    Submission.objects.filter(pk=twin["submission"].pk).update(status="done")  # nothing of theirs waiting
    with override_settings(QUEUE_SYNC=False):
        posted = _client("anonymous", world).post(
            reverse("api-submit", kwargs={"name": twin["submission"].assignment.name}),
            data=json.dumps({"config": OFFICIAL}), content_type="application/json", HTTP_AUTHORIZATION=f"Bearer {choi}")
    assert twin["submission"].assignment.name == a_sub.assignment.name
    if posted.status_code != 201 or Submission.objects.get(pk=posted.json()["id"]).assignment != twin[
            "submission"].assignment:
        wrong.append(f"a student of the other class submitting: {posted.status_code}, {posted.content[:200]!r}")

    token = world["tokens"]["teacher"]
    world["tokens"]["teacher"] = twin["token"]
    try:
        anon = _client("anonymous", world)
        for name, pattern in routes():
            if not name.startswith("api-"):
                continue
            got = _answer(_request(anon, "teacher", name, RULES[name][0], _url(name, pattern, world), world))
            if got != RULES[name][1]["other_teacher"]:
                wrong.append(f"the other class's token {name}: {got}, expected {RULES[name][1]['other_teacher']}")
    finally:
        world["tokens"]["teacher"] = token
    assert not wrong, "\n".join(wrong)


def _state() -> tuple[Any, ...]:
    """What a request could change: every table's rows, and the moderation flags."""
    from django.apps import apps

    from robokit.server.models import Result, Submission

    counts = tuple(sorted((m._meta.label, m.objects.count()) for m in apps.get_models()
                          if m._meta.label not in ("sessions.Session", "admin.LogEntry")))
    flags = (tuple(Result.objects.order_by("pk").values_list("excluded", flat=True)),
             tuple(Submission.objects.order_by("pk").values_list("excluded", "status")))
    return counts, flags


@pytest.mark.slow
def test_every_route_under_every_method_lets_no_role_past_its_rule(world: dict[str, Any]) -> None:
    """Each route asked with every HTTP method (GET, POST, PUT, PATCH, DELETE) by every role: a role the rules
    turn away from a route is turned away under every method (a login redirect, 401, 403, 404, 405 or 409, never a
    page or a change), and a method other than the route's own changes nothing for anyone."""
    denied = {LOGIN, ADMIN_LOGIN, 401, 403, 404, 405, 409}
    wrong = []
    found = [(n, p) for n, p in routes() if n not in ("logout", "me-logout", "admin", "login", "me")]
    for role in ROLES:
        c = _client(role, world)
        token = world["tokens"][role]
        headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
        for name, pattern in found:
            own_method, rule = RULES[name]
            url = _url(name, pattern, world)
            for method in ("GET", "POST", "PUT", "PATCH", "DELETE"):
                if method == own_method:
                    continue
                before = _state()
                if method == "GET":
                    resp = c.get(url, **headers)
                else:
                    resp = getattr(c, method.lower())(url, data=json.dumps({"reason": "x", "run_id": "y"}),
                                                       content_type="application/json", **headers)
                got = _answer(resp)
                if rule[role] in denied and got not in denied:
                    wrong.append(f"{role} {method} {name}: {got}, turned away under {own_method} "
                                 f"({rule[role]})")
                if _state() != before:
                    wrong.append(f"{role} {method} {name}: changed the server's state")
    assert not wrong, "\n".join(wrong)
