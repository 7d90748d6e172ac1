"""Every route of the course server against the roles a school has beyond a class's own teacher and students.

An administrator (a superuser: "sees every class"), a teacher who owns no class yet, a logged-in account that is not
staff, a deactivated teacher, a student enrolled in two classes (a token for each: the browser's session opened with
one, the terminal holding the other), a revoked token. The routes come from the URL configuration, so a route
added tomorrow is asked by these tests the day it is added.

The expected answer is not a table of role -> status but a plain second computation from the facts a role carries
(who is logged in and whether the account is active, staff or superuser, which classes it owns; which student's
token opened the browser's session; which token the ``Authorization`` header carries), written from docs/server.md:
teacher pages open for a logged-in account owning the class (a superuser owns every class), 404 for another, the
login page for nobody logged in; a run and its files are the teacher's and the student's who posted it (the
student by the session, a page never by a token); the API goes by the token alone, and a teacher token is a
class's, whoever holds it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import pytest
from course_helpers import robokit_payload, tiny_png
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

LOGIN = "login"  # a redirect to the teacher's login page
ADMIN_LOGIN = "admin-login"  # a redirect to the admin's login page
TEACHER_PAGES = ("classroom", "leaderboard", "history", "export-csv", "assignment", "assignment-chart", "dashboard",
                 "student-chart", "moderation", "moderate", "submission", "reevaluate", "grades-csv", "grades-xlsx")
PAST_THE_DOOR = {"moderate": 400, "reevaluate": 400}  # a POST without its reason: the owner is told what is missing


@dataclass(frozen=True)
class User:
    owns: frozenset[str] = frozenset()  # class keys
    staff: bool = True
    superuser: bool = False


@dataclass(frozen=True)
class Tok:
    classroom: str  # class key
    student: str | None = None  # student key; None: a teacher token
    revoked: bool = False
    teacher: str | None = None  # a teacher token's holder (a key of USERS): refused once that account is deactivated


# the world's facts: two classes, their people, the tokens; the objects asked for are all class A's: 김민준's
# verified run with a file, his submission to A's assignment
USERS = {"teacher": User(frozenset({"A"})), "other_teacher": User(frozenset({"B"})),
         "admin": User(superuser=True), "idle_teacher": User(), "plain": User(staff=False)}
STUDENTS = {"kim": "A", "lee": "A", "park": "B", "kim_b": "B"}  # kim_b: 김민준 enrolled in class B too
TOKENS = {**{s: Tok(c, s) for s, c in STUDENTS.items()}, "park_old": Tok("B", "park", revoked=True),
          "teacher_A": Tok("A", teacher="teacher"), "teacher_B": Tok("B", teacher="other_teacher"),
          "admin_B": Tok("B", teacher="admin")}
OWNER, CLASS = "kim", "A"  # whose run and submission the URLs name, and their class


@dataclass(frozen=True)
class Who:
    login: str | None = None  # a key of USERS
    session: str | None = None  # the student whose token opened /me/ in this browser
    token: str | None = None  # the token sent as Authorization
    inactive: bool = False  # the logged-in account was deactivated since it logged in
    label: str = field(default="", compare=False)


def expected(route: str, who: Who) -> Any:
    """What ``who`` gets from ``route`` (a status code, LOGIN or ADMIN_LOGIN), from docs/server.md's rules."""
    user = USERS[who.login] if who.login is not None and not who.inactive else None  # a deactivated login is none
    owns_class = user is not None and (user.superuser or CLASS in user.owns)
    tok = TOKENS[who.token] if who.token is not None else None
    if route in ("login", "me", "replay-viewer", "replay-script"):
        return 200
    if route in ("logout", "me-logout"):
        return 302
    if route == "home":  # a student's session (and nobody logged in) goes on to /me/
        return 302 if user is None and who.session is not None else 200
    if route == "admin":
        return 200 if user is not None and user.staff else ADMIN_LOGIN
    if route == "my-training-chart":
        return 200 if who.session is not None else 404
    if route in TEACHER_PAGES:
        if user is None:
            return LOGIN
        return PAST_THE_DOOR.get(route, 200) if owns_class else 404
    if route in ("run", "artifact"):
        if owns_class or who.session == OWNER:
            return 200
        return LOGIN if route == "run" and user is None and who.session is None else 404
    # the API: the token alone
    assert route.startswith("api-"), f"route {route!r} has no rule in this test: add it to expected()"
    if tok is not None and (tok.revoked or (who.inactive and tok.teacher is not None and tok.teacher == who.login)):
        return 401  # revoked, or a teacher token whose holder's account was deactivated
    if route == "api-submission":  # its student's token, or a teacher token of its class
        mine = tok is not None and (tok.student == OWNER or (tok.student is None and tok.classroom == CLASS))
        return 200 if mine else 404
    if route == "api-result":  # the run id posted again: its owner gets the first record back
        return 200 if tok is not None and tok.student == OWNER else 409
    if route == "api-artifacts":  # the run's owner or a teacher token of its class
        if tok is None:
            return 401
        if tok.classroom != CLASS:
            return 403
        return 201 if tok.student in (None, OWNER) else 403
    if route in ("api-submit", "api-training"):  # a student's token; an empty post is told what is missing
        if tok is None:
            return 401
        if tok.student is None:
            return 403
        if route == "api-submit" and tok.classroom != CLASS:
            return 404  # their class has no assignment of that name
        return 400
    raise AssertionError(f"route {route!r} has no rule in this test: add it to expected()")


def routes() -> list[tuple[str, str]]:
    """(name, pattern) of every route of the URL configuration; an include (the admin) by its namespace."""
    from django.urls import get_resolver
    from django.urls.resolvers import URLPattern, URLResolver

    out = []
    for p in get_resolver().url_patterns:
        if isinstance(p, URLPattern):
            out.append((str(p.name), str(p.pattern)))
        elif isinstance(p, URLResolver):
            out.append((p.namespace or str(p.pattern), str(p.pattern)))
    return out


METHOD = {"logout": "POST", "me-logout": "POST", "moderate": "POST", "reevaluate": "POST", "api-result": "POST",
          "api-artifacts": "POST", "api-submit": "POST", "api-training": "POST"}


@pytest.fixture
def world(course: Any, settings: Any, tmp_path: Any, client: Any) -> dict[str, Any]:
    """Class A (the course's) with 김민준's run, its file and his submission; class B of another teacher with 박지호
    and 김민준 enrolled again; an administrator, a teacher of no class, an account that is not staff."""
    from course_work import OFFICIAL, make_assignment
    from django.contrib.auth import get_user_model
    from django.urls import reverse

    from robokit.server import tokens
    from robokit.server.models import Classroom, Project, Student, Submission

    settings.MEDIA_ROOT = tmp_path / "media"
    make = get_user_model().objects.create_user
    users = {"teacher": course.teacher, "other_teacher": make("other-teacher", password="x", is_staff=True),
             "admin": make("admin", password="x", is_staff=True, is_superuser=True),
             "idle_teacher": make("new-teacher", password="x", is_staff=True), "plain": make("plain", password="x")}
    room_b = Classroom.objects.create(name="2반", owner=users["other_teacher"])
    park = Student.objects.create(classroom=room_b, name="박지호")
    kim_b = Student.objects.create(classroom=room_b, name="김민준")
    park_old = tokens.issue_student_token(park)
    raw = {"kim": course.kim_token, "lee": course.lee_token, "park": tokens.issue_student_token(park),
           "park_old": park_old, "kim_b": tokens.issue_student_token(kim_b), "teacher_A": course.teacher_token,
           "teacher_B": tokens.issue_teacher_token(room_b, users["other_teacher"]),
           "admin_B": tokens.issue_teacher_token(room_b, users["admin"])}
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
    values = {"pk": course.room.pk, "project_pk": project.pk, "student_pk": course.kim.pk, "spk": course.kim.pk,
              "apk": assignment.pk, "run_id": payload["run_id"], "name": assignment.name}
    by_route = {"artifact": {"pk": int(artifact["url"].split("/")[2]), "name": artifact["name"]},
                "submission": {"pk": sub.pk}, "reevaluate": {"pk": sub.pk}, "api-submission": {"pk": sub.pk},
                "assignment-chart": {"kind": "reasons"}, "student-chart": {"kind": "weekly"}}
    from django.urls.resolvers import RoutePattern

    urls = {}
    for name, pattern in routes():
        if name == "admin":
            urls[name] = "/admin/"
            continue
        params = RoutePattern(pattern).converters.keys()
        given_ = {**values, **by_route.get(name, {})}
        missing = [p for p in params if p not in given_]
        assert not missing, f"route {name!r} ({pattern}) takes {missing}: give this test a value for them"
        urls[name] = reverse(name, kwargs={p: given_[p] for p in params})
    assert set(METHOD) <= set(urls), f"METHOD names routes the server no longer has: {set(METHOD) - set(urls)}"
    return {"users": users, "tokens": raw, "payload": payload, "urls": urls, "uploads": [0]}


def _upload(name: str, content: bytes) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    return SimpleUploadedFile(name, content)


def _client(who: Who, world: dict[str, Any]) -> Any:
    from django.test import Client

    c = Client()
    if who.session is not None:
        opened = c.post("/me/", {"token": world["tokens"][who.session]})
        assert opened.status_code == 302, (who, opened.status_code)
    if who.login is not None:
        c.force_login(world["users"][who.login])
    return c


def _ask(c: Any, who: Who, name: str, world: dict[str, Any]) -> Any:
    url = world["urls"][name]
    token = world["tokens"][who.token] if who.token is not None else None
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    method = METHOD.get(name, "GET")
    if method == "GET":
        resp = c.get(url, **headers)
    elif name == "api-result":
        resp = c.post(url, data=json.dumps(world["payload"]), content_type="application/json", **headers)
    elif name == "api-artifacts":  # bytes no other request sent, so an upload that gets in stores a new file
        world["uploads"][0] += 1
        n = world["uploads"][0]
        resp = c.post(url, data={"f": _upload(f"u{n}.png", tiny_png(width=2 + n))}, **headers)
    elif name.startswith("api-"):
        resp = c.post(url, data="{}", content_type="application/json", **headers)
    else:
        resp = c.post(url, {}, **headers)
    if resp.status_code == 302 and resp["Location"].startswith("/accounts/login/"):
        return LOGIN
    if resp.status_code == 302 and resp["Location"].startswith("/admin/login/"):
        return ADMIN_LOGIN
    return resp.status_code


def _deactivate(who: Who, world: dict[str, Any], inactive: bool) -> None:
    if who.login is not None:
        user = world["users"][who.login]
        user.is_active = not inactive
        user.save(update_fields=["is_active"])


def _wrong(who: Who, world: dict[str, Any]) -> list[str]:
    """Every route asked by ``who`` (the session-ending ones last), each answer against :func:`expected`."""
    c = _client(who, world)
    _deactivate(who, world, who.inactive)
    try:
        names = [n for n, _ in routes() if n not in ("logout", "me-logout")] + ["me-logout", "logout"]
        wrong = []
        for name in names:
            got, want = _ask(c, who, name, world), expected(name, who)
            if got != want:
                wrong.append(f"{who.label or who}: {name} answered {got}, expected {want}")
        return wrong
    finally:
        _deactivate(who, world, False)


ROLES = [
    Who(login="admin", token="admin_B", label="an administrator (superuser) holding a teacher token of class B"),
    Who(login="idle_teacher", label="a teacher who owns no class"),
    Who(login="plain", label="a logged-in account that is not staff"),
    Who(session="kim_b", token="kim_b", label="김민준 signed in with his class-B token"),
    Who(session="kim", token="kim_b", label="김민준's class-A session, his class-B token in the terminal"),
    Who(session="kim_b", token="kim", label="김민준's class-B session, his class-A token in the terminal"),
    Who(login="teacher", token="teacher_A", inactive=True, label="the class's teacher, deactivated"),
    Who(session="park", token="park_old", label="박지호 with his revoked token"),
]


# ASCII ids: mutmut hands pytest the node ids it collected, and an escaped Korean id is not found again
IDS = ["admin", "teacher-of-no-class", "not-staff", "student-of-two-classes", "class-a-session-class-b-token",
       "class-b-session-class-a-token", "deactivated-teacher", "revoked-token"]


@pytest.mark.parametrize("who", ROLES, ids=IDS)
def test_every_route_answers_each_role_as_the_rules_compute(world: dict[str, Any], who: Who) -> None:
    unruled = [n for n, _ in routes() if n != "admin" and n not in METHOD and n not in TEACHER_PAGES
               and n not in ("home", "login", "me", "replay-viewer", "replay-script", "my-training-chart",
                             "run", "artifact", "api-submission")]
    assert not unruled, f"routes with no rule in this test: {unruled} (add each to expected())"
    wrong = _wrong(who, world)
    assert not wrong, "\n".join(wrong)


def test_an_administrator_sees_every_class_on_the_home_page_and_a_teacher_of_none_sees_none(
        world: dict[str, Any]) -> None:
    """The home page lists the classes a login may open: every class for a superuser, its own for a teacher,
    none for a teacher of no class -- the same classes whose pages answer 200."""
    from django.urls import reverse

    from robokit.server.models import Classroom

    rooms = {c.name: c.pk for c in Classroom.objects.all()}
    for login, sees in (("admin", {"1반", "2반"}), ("teacher", {"1반"}), ("other_teacher", {"2반"}),
                        ("idle_teacher", set())):
        c = _client(Who(login=login), world)
        page = c.get("/").content.decode()
        listed = {name for name in rooms if reverse("classroom", kwargs={"pk": rooms[name]}) in page}
        assert listed == sees, (login, listed)
        opens = {name for name, pk in rooms.items()
                 if c.get(reverse("classroom", kwargs={"pk": pk})).status_code == 200}
        assert opens == sees, (login, opens)


def _who() -> Any:
    return st.builds(Who, login=st.none() | st.sampled_from(sorted(USERS)),
                     session=st.none() | st.sampled_from(sorted(STUDENTS)),
                     token=st.none() | st.sampled_from(sorted(TOKENS)), inactive=st.booleans())


@pytest.mark.slow
@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(who=_who())
def test_any_mix_of_login_session_and_token_gets_what_the_rules_compute(world: dict[str, Any], who: Who) -> None:
    """A browser holding any login (active or deactivated), any student's session and any token at once: every
    route answers what the rules compute from those facts -- no credential opens more than its own rule."""
    wrong = _wrong(who, world)
    assert not wrong, "\n".join(wrong)


# ----------------------------------------------------------------------------------------------- what the pages show
def _fmt(value: Any) -> str:
    """A figure as the pages print it: whole numbers as they are, other numbers to 4 significant digits (whole
    above 10 000)."""
    if isinstance(value, float):
        return f"{value:.4g}" if abs(value) < 1e4 else f"{value:.0f}"
    return str(value)


def _cells(html_text: str, table_class: str) -> list[list[str]]:
    import html
    import re

    body = re.search(rf'<table class="{table_class}">(.*?)</table>', html_text, re.S)
    assert body, f"no {table_class} table"
    return [[html.unescape(c) for c in re.findall(r"<t[hd][^>]*>(.*?)</t[hd]>", row, re.S)]
            for row in re.findall(r"<tr>(.*?)</tr>", body.group(1), re.S)]


@pytest.fixture
def rich_run(world: dict[str, Any], client: Any) -> dict[str, Any]:
    """김민준's run with objects of different columns, figures, a video, two plots, a trace with state transitions
    and the config file; its sim time (16 s) is not its ``total_time`` (20 s)."""
    from course_helpers import mp4_head

    objects = [{"colour": "red", "detected_position": [0.4, 0.1, 0.025], "outcome": "sorted", "label": "빨간 상자"},
               {"colour": "blue", "grasp_attempts": 2, "error_m": 0.0123456, "note": None}]
    payload = robokit_payload(8, objects=objects, red_sorted=3, blue_sorted=1, failures=0, total_time=20.0,
                              mean_speed=0.123456)
    token = world["tokens"]["kim"]
    posted = client.post("/api/robotics/result/", data=json.dumps(payload), content_type="application/json",
                         HTTP_AUTHORIZATION=f"Bearer {token}")
    assert posted.status_code == 201, posted.content
    moves = [(4.0, "IDLE", "PICK"), (12.0, "PICK", "PLACE")]
    trace = "".join(json.dumps({"kind": "transition", "t": t, "machine": "sort", "source_state": a,
                                "dest_state": b, "trigger": f"to_{b.lower()}"}) + "\n" for t, a, b in moves)
    import base64
    import struct

    replay = {"links": ["box"], "shapes": [], "meshes": [], "frames": [], "machines": [], "duration": 16.0,
              "t": base64.b64encode(struct.pack("<f", 0.0)).decode(),
              "poses": base64.b64encode(struct.pack("<7f", 0, 0, 0.05, 0, 0, 0, 1)).decode()}
    files = {"clip.mp4": mp4_head(), "plot.png": tiny_png(5), "curve.png": tiny_png(6),
             "trace.jsonl": trace.encode(), "sort_robot.toml": b"[world]\nmax_time = 30.0\n",
             "replay.json": json.dumps(replay).encode()}
    up = client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                     data={n: _upload(n, c) for n, c in files.items()}, HTTP_AUTHORIZATION=f"Bearer {token}")
    assert up.status_code == 201, up.content
    links = {a["name"]: a["url"] for a in up.json()["artifacts"]}
    return {"payload": payload, "objects": objects, "moves": moves, "links": links, "sim_time": 16.0,
            "config_text": files["sort_robot.toml"].decode()}


def test_the_run_page_shows_everything_the_run_holds_to_each_role_that_may_see_it(
        world: dict[str, Any], rich_run: dict[str, Any]) -> None:
    """The class's teacher, an administrator and the student who posted it see, on the run page: every figure
    (formatted), every object in a table of the columns of all objects, the videos as videos and the plots as
    images (each by its own link), the state timeline over the run's sim time, the config's text, the payload as
    posted (indented JSON, the config by its file name) and the 3D replay of its ``replay.json``. The teacher's page
    (and the administrator's) carries the moderation form with its CSRF token; the student's has none."""
    import html
    import re

    from robokit.server.models import Result

    run_id = rich_run["payload"]["run_id"]
    record = Result.objects.get(run_id=run_id)
    cols: list[str] = []
    for o in rich_run["objects"]:
        cols += [k for k in o if k not in cols]

    def cell(v: Any) -> str:
        if v is None:
            return ""
        if isinstance(v, float):
            return _fmt(v)
        return json.dumps(v, ensure_ascii=False) if isinstance(v, (list, dict)) else str(v)

    objects = [cols] + [[cell(o.get(c)) for c in cols] for o in rich_run["objects"]]
    figures = [[k, _fmt(v)] for k, v in record.figures.items()]
    assert {"red_sorted", "mean_speed", "total_time"} <= set(record.figures)
    end = rich_run["sim_time"]
    starts = [0.0] + [t for t, _, _ in rich_run["moves"]]
    widths = [round((b - a) / end * 100, 3) for a, b in zip(starts, [*starts[1:], end], strict=True)]
    links = rich_run["links"]
    for who in (Who(login="teacher"), Who(login="admin"), Who(session="kim")):
        page = _client(who, world).get(f"/runs/{run_id}/").content.decode()
        shown_objects = _cells(page, "objects")  # columns in any order: PostgreSQL's jsonb keeps no key order
        head = shown_objects[0]
        assert sorted(head) == sorted(objects[0]), who
        assert [dict(zip(head, row, strict=True)) for row in shown_objects[1:]] == \
            [dict(zip(objects[0], row, strict=True)) for row in objects[1:]], who
        assert sorted(_cells(page, "figures")) == sorted(figures), who
        assert re.findall(r"<video [^>]*src=\"([^\"]+)\"", page) == [links["clip.mp4"]], who
        assert sorted(re.findall(r"<img src=\"([^\"]+)\"", page)) == sorted([links["plot.png"], links["curve.png"]])
        assert [float(w) for w in re.findall(r'class="seg[^"]*" style="width: ([\d.]+)%"', page)] == widths, who
        assert re.findall(r"data-src='([^']+)'", page) == [links["replay.json"]], who  # the 3D replay, drawn
        shown = re.search(r'<pre class="config">(.*?)</pre>', page, re.S)
        assert shown and html.unescape(shown.group(1)) == rich_run["config_text"], who
        block = re.search(r"<summary>Payload as posted</summary><pre>(.*?)</pre>", page, re.S)
        assert block, who
        text = html.unescape(block.group(1))
        assert json.loads(text) == {**rich_run["payload"], "config": "sort_robot.toml"}, who
        assert text.startswith('{\n  "'), "the payload is shown indented by two spaces, a key a line"
        assert "빨간 상자" in text, "Korean in the payload is shown as itself, not as \\u escapes"
        facts = re.search(r"<dt>config</dt><dd>(.*?)</dd>", page, re.S)
        assert facts and re.sub(r"<[^>]+>", "", facts.group(1)) == f"sort_robot.toml, seed {record.seed}", who
        form = re.search(r'<form method="post" action="[^"]*" class="moderate">(.*?)</form>', page, re.S)
        if who.login is not None:
            assert form and 'name="csrfmiddlewaretoken"' in form.group(1), who
        else:
            assert form is None, who


def test_an_older_run_stored_with_its_config_path_shows_only_the_file_name(world: dict[str, Any]) -> None:
    """A run stored before the server kept only the config's file name: its page names the file and never the
    folders it was in (a student's local folders are often named after them)."""
    from robokit.server.models import Project, Result, Student

    kim = Student.objects.get(name="김민준", classroom__name="1반")
    path = "/home/kimminjun/robots/sort_robot.toml"
    Result.objects.create(run_id="old-run-1", classroom=kim.classroom, project=Project.objects.get(name="A"),
                          student=kim, student_name=kim.name, verified=True, outcome="succeeded",
                          config=path, payload={"config": path, "outcome": "succeeded"})
    page = _client(Who(login="teacher"), world).get("/runs/old-run-1/").content.decode()
    assert "sort_robot.toml" in page and "kimminjun" not in page


def test_the_home_page_counts_each_class_students_and_results(world: dict[str, Any], client: Any) -> None:
    """Each login's home page: one row per class it may open, with that class's number of students and of
    results (counted here, plainly), and whether it takes posts without a token; a teacher of no class is told
    how to make one, named by their login; nobody signed in sees where results are posted; a student's session
    goes on to ``/me/``."""
    import re

    from robokit.server.models import Classroom, Result, Student

    more = robokit_payload(9, student="lee")
    assert client.post("/api/robotics/result/", data=json.dumps(more), content_type="application/json",
                       HTTP_AUTHORIZATION=f"Bearer {world['tokens']['lee']}").status_code == 201
    rows = {c.name: [c.name, str(Student.objects.filter(classroom=c).count()),
                     str(Result.objects.filter(classroom=c).count()),
                     "accepted (unverified)" if c.allow_unverified else "refused"] for c in Classroom.objects.all()}
    assert rows["1반"][1:3] == ["2", "2"]  # two students and two runs: a count over both joins would say 4
    for login, names in (("admin", ["1반", "2반"]), ("teacher", ["1반"]), ("other_teacher", ["2반"])):
        page = _client(Who(login=login), world).get("/").content.decode()
        got = [[re.sub(r"<[^>]+>", "", c).strip() for c in re.findall(r"<td>(.*?)</td>", row, re.S)]
               for row in re.findall(r"<tr>(.*?)</tr>", page, re.S) if "<td>" in row]
        assert sorted(got) == sorted(rows[n] for n in names), login
    idle = _client(Who(login="idle_teacher"), world).get("/").content.decode()
    assert "No class yet" in idle and "--teacher new-teacher" in idle
    welcome = _client(Who(), world).get("/").content.decode()
    assert "http://testserver/api/robotics/result/" in welcome
    assert _client(Who(session="kim"), world).get("/")["Location"] == "/me/"


def test_every_api_refusal_says_what_is_wrong_in_its_field_and_header(world: dict[str, Any]) -> None:
    """Each API route from the URL configuration, asked with each kind of bad credential, method or body the docs
    list (docs/server.md, "The course API" and the result API's refusals): one JSON object ``{"error", "field"}``
    whose error starts with what is wrong (a field's refusal with the field); a 401 carries ``WWW-Authenticate:
    Bearer``, a 405 ``Allow: POST``."""
    api = [n for n, _ in routes() if n.startswith("api-")]
    revoked = world["tokens"]["park_old"]
    cases = {"malformed": ("Token abc", 401, "Authorization", "malformed Authorization header"),
             "empty bearer": ("Bearer ", 401, "Authorization", "malformed Authorization header"),
             "unknown": ("Bearer rks_not-a-token", 401, "Authorization", "unknown token"),
             "revoked": (f"Bearer {revoked}", 401, "Authorization", "revoked token")}
    wrong = []

    def check(label: str, resp: Any, status: int, field: str | None, starts: str, **headers: str) -> None:
        try:
            body = resp.json()
        except ValueError:
            body = None
        if resp.status_code != status or not isinstance(body, dict) or set(body) != {"error", "field"} or \
                body["field"] != field or not str(body["error"]).startswith(starts):
            wrong.append(f"{label}: {resp.status_code} {body}, expected {status} field {field!r} '{starts}…'")
            return
        for name, value in headers.items():
            if not str(resp.get(name, "")).startswith(value):
                wrong.append(f"{label}: header {name} is {resp.get(name)!r}, expected {value!r}…")

    c = _client(Who(), world)
    for name in api:
        url, method = world["urls"][name], METHOD.get(name, "GET")
        for case, (header, status, where, starts) in cases.items():
            ask = c.get if method == "GET" else c.post
            resp = ask(url, data="{}", content_type="application/json", HTTP_AUTHORIZATION=header) \
                if method == "POST" else ask(url, HTTP_AUTHORIZATION=header)
            check(f"{name} {case}", resp, status, where, starts, **{"WWW-Authenticate": "Bearer"})
        if method == "POST":
            check(f"{name} GET", c.get(url), 405, None, "POST", Allow="POST")
        if name in ("api-result", "api-submit", "api-training"):
            resp = c.post(url, data="config = 1", content_type="text/plain",
                          HTTP_AUTHORIZATION=f"Bearer {world['tokens']['kim']}")
            check(f"{name} text/plain", resp, 415, "Content-Type", "Content-Type: send ")
            if "'text/plain'" not in resp.json().get("error", ""):
                wrong.append(f"{name} text/plain: the error does not name the type sent: {resp.json()}")
    teacher = f"Bearer {world['tokens']['teacher_A']}"
    for name in ("api-submit", "api-training"):
        resp = c.post(world["urls"][name], data="{}", content_type="application/json", HTTP_AUTHORIZATION=teacher)
        check(f"{name} teacher token", resp, 403, "Authorization", "Authorization: only a student's token")
    for name, starts in (("api-submit", "no token sent"), ("api-training", "no token sent"),
                         ("api-artifacts", "no token sent")):
        resp = c.post(world["urls"][name], data="{}", content_type="application/json")
        check(f"{name} no token", resp, 401, "Authorization", starts, **{"WWW-Authenticate": "Bearer"})
    check("api-submission no token", c.get(world["urls"]["api-submission"]), 404, "submission", "submission: no such")
    other = f"Bearer {world['tokens']['lee']}"
    check("api-submission classmate", c.get(world["urls"]["api-submission"], HTTP_AUTHORIZATION=other), 404,
          "submission", "submission: no such")
    assert not wrong, "\n".join(wrong)


def test_a_file_is_served_with_its_type_and_the_headers_that_keep_it_private(world: dict[str, Any],
                                                                            rich_run: dict[str, Any]) -> None:
    """Every uploaded file of a run, to each role that may see it: the bytes uploaded, its type by kind (or by its
    name for a row stored without one), a sandboxing Content-Security-Policy, a cache that is the browser's only
    (``private``), byte ranges for seeking; a file whose bytes are gone answers 404."""
    from pathlib import Path

    from django.conf import settings as django_settings

    from robokit.server.models import Artifact

    types = {"clip.mp4": "video/mp4", "plot.png": "image/png", "curve.png": "image/png"}
    for who in (Who(login="teacher"), Who(login="admin"), Who(session="kim")):
        c = _client(who, world)
        for name, ctype in types.items():
            resp = c.get(rich_run["links"][name])
            body = b"".join(resp.streaming_content) if resp.streaming else resp.content
            art = Artifact.objects.get(name=name, result__run_id=rich_run["payload"]["run_id"])
            assert body == (Path(django_settings.MEDIA_ROOT) / art.path).read_bytes(), (who, name)
            assert resp["Content-Type"] == ctype, (who, name)
            assert resp["Content-Security-Policy"] == "default-src 'none'; style-src 'unsafe-inline'; sandbox"
            assert resp["Cache-Control"] == "private, max-age=3600" and resp["Accept-Ranges"] == "bytes"
    art = Artifact.objects.get(name="plot.png", result__run_id=rich_run["payload"]["run_id"])
    Artifact.objects.filter(pk=art.pk).update(content_type="")
    c = _client(Who(login="teacher"), world)
    assert c.get(rich_run["links"]["plot.png"].replace("plot.png", "curve.png")).status_code == 404  # its own name
    assert c.get(rich_run["links"]["plot.png"])["Content-Type"] == "image/png"
    (Path(django_settings.MEDIA_ROOT) / art.path).unlink()
    assert c.get(rich_run["links"]["plot.png"]).status_code == 404


def test_revoking_a_students_tokens_keeps_when_each_earlier_one_was_revoked(world: dict[str, Any]) -> None:
    """``revoke_token`` (and the admin's *Revoke tokens*) revokes the active token and says how many it revoked;
    a token revoked before keeps the time it was revoked (the admin's token list shows when)."""
    from robokit.server import tokens
    from robokit.server.models import Student, Token

    park = Student.objects.get(name="박지호")
    before = {t.pk: t.revoked_at for t in Token.objects.filter(student=park)}
    assert sum(v is None for v in before.values()) == 1 and len(before) == 2
    assert tokens.revoke_student_tokens(park) == 1
    after = {t.pk: t.revoked_at for t in Token.objects.filter(student=park)}
    assert all(after[pk] == when for pk, when in before.items() if when is not None)
    assert all(when is not None for when in after.values())
    assert tokens.revoke_student_tokens(park) == 0


def _moderation_world(world: dict[str, Any], client: Any) -> dict[str, Any]:
    """A run and a submission in each class: 김민준's in class A (the world's), 박지호's in class B."""
    from course_work import OFFICIAL, make_assignment

    from robokit.server.models import Classroom, Result, Student, Submission

    payload = robokit_payload(11, student="park")
    assert client.post("/api/robotics/result/", data=json.dumps(payload), content_type="application/json",
                       HTTP_AUTHORIZATION=f"Bearer {world['tokens']['park']}").status_code == 201
    room_b = Classroom.objects.get(name="2반")
    park = Student.objects.get(name="박지호")
    sub_b = Submission.objects.create(assignment=make_assignment(room_b), student=park, config_text=OFFICIAL)
    rooms = {"A": Classroom.objects.get(name="1반").pk, "B": room_b.pk}
    return {"rooms": rooms,
            "objects": {("run", "A"): Result.objects.get(run_id=world["payload"]["run_id"]).run_id,
                        ("run", "B"): payload["run_id"],
                        ("submission", "A"): Submission.objects.exclude(pk=sub_b.pk).get().pk,
                        ("submission", "B"): sub_b.pk}}


def _flags() -> dict[tuple[str, Any], bool]:
    from robokit.server.models import Result, Submission

    return {**{("run", r): x for r, x in Result.objects.values_list("run_id", "excluded")},
            **{("submission", s): x for s, x in Submission.objects.values_list("pk", "excluded")}}


@pytest.mark.parametrize("full", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["exclude", "all"])
def test_every_moderation_through_every_class_url_changes_only_the_owners_own_objects(world: dict[str, Any],
                                                                                       client: Any, full: bool) -> None:
    """Every teacher login (the class's teacher, the other class's, an administrator, a teacher of no class)
    excluding and putting back every run and submission (of either class) through either class's moderation URL:
    it takes effect exactly when the login may open that class (a superuser may open every class) and the object
    is that class's; otherwise 404 and no flag of any object changes, and no moderation log line is written. The
    default tier excludes, with the two classes' teachers; the slow tier puts back too, with every login."""
    from django.urls import reverse

    from robokit.server.models import ModerationEvent

    mod = _moderation_world(world, client)
    owners = {"teacher": {"A"}, "other_teacher": {"B"}, "admin": {"A", "B"}, "idle_teacher": set()}
    if not full:
        owners = {k: owners[k] for k in ("teacher", "other_teacher")}
    wrong = []
    for login, opens in owners.items():
        c = _client(Who(login=login), world)
        for url_class, room in mod["rooms"].items():
            for (kind, obj_class), ident in mod["objects"].items():
                for action in ("exclude", "include") if full else ("exclude",):
                    before, log = _flags(), ModerationEvent.objects.count()
                    field = "run_id" if kind == "run" else "submission"
                    resp = c.post(reverse("moderate", kwargs={"pk": room}),
                                  {field: ident, "action": action, "reason": "a generated check"})
                    takes = url_class in opens and obj_class == url_class
                    want = {**before, (kind, ident): action == "exclude"} if takes else before
                    label = f"{login} {action} {kind} of {obj_class} through class {url_class}"
                    if resp.status_code != (302 if takes else 404):
                        wrong.append(f"{label}: {resp.status_code}")
                    if _flags() != want or ModerationEvent.objects.count() != log + takes:
                        wrong.append(f"{label}: flags or the moderation log changed as they should not")
    assert not wrong, "\n".join(wrong)
