"""The class's CSV download against the results posted, over generated posts.

Each generated class receives a mix of posts -- a student's token, the class's teacher token (official), none
(lesson 08's code, unverified) -- with generated names, projects and figures, some starting like a spreadsheet
formula. The CSV the teacher downloads is read back with the ``csv`` module and each row compared with the post it
came from, in the order they were posted: who it is under (the token's student, or the name posted), the name as
posted, verified and official as the token says, every figure as sent, and every text cell that would start a
formula prefixed with ``'`` (docs/server.md, "What the teacher sees").
"""

from __future__ import annotations

import csv
import io
from typing import Any

import pytest
from course_helpers import PASSWORD, post
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=6, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
NAMES = ("홍길동", "=1+2", "+x", "-3", "@SUM(A1)", "plain", "'quoted")
count = st.one_of(st.none(), st.integers(0, 9))
posts = st.lists(st.fixed_dictionaries({
    "who": st.sampled_from(["kim", "lee", "teacher", None]), "student": st.sampled_from(NAMES),
    "project": st.sampled_from(["A", "물체 분류", "=B"]), "red_sorted": count, "blue_sorted": count,
    "failures": count, "total_time": st.one_of(st.none(), st.floats(0, 500).map(lambda v: round(v, 3)))}),
    min_size=1, max_size=5)


def safe(text: str) -> str:
    """A spreadsheet cell as text: what would start a formula gets a leading apostrophe."""
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


def number(value: Any) -> str:
    return "" if value is None else str(value)


@pytest.fixture
def teacher_client(client: Any, course: Any) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


@PROPS
@given(posts)
def test_every_csv_row_is_the_post_it_came_from(teacher_client: Any, course: Any, sent: list[dict[str, Any]]) -> None:
    from robokit.server.models import Result

    Result.objects.all().delete()
    tokens = {"kim": course.kim_token, "lee": course.lee_token, "teacher": course.teacher_token, None: None}
    for p in sent:
        body = {k: v for k, v in p.items() if k != "who" and v is not None}
        assert post(teacher_client, body, tokens[p["who"]]).status_code == 201
    resp = teacher_client.get(f"/classes/{course.room.pk}/results.csv")
    assert resp.status_code == 200 and resp.content.startswith("\ufeff".encode())
    rows = list(csv.DictReader(io.StringIO(resp.content.decode("utf-8-sig"))))
    assert len(rows) == len(sent)
    for row, p in zip(rows, sent, strict=True):
        under = {"kim": course.kim.name, "lee": course.lee.name}.get(p["who"], p["student"])
        assert row["student"] == safe(under) and row["posted_student"] == safe(p["student"])
        assert row["verified"] == str(p["who"] is not None) and row["official"] == str(p["who"] == "teacher")
        assert row["class"] == safe(course.room.name) and row["project"] == safe(p["project"])
        for key in ("red_sorted", "blue_sorted", "failures", "total_time"):
            assert row[key] == number(p[key]), key
