"""Two course figures a teacher reads per student, over generated histories: the dashboard's ISO weeks and the grade
sheet's count of submissions.

docs/server.md: the dashboard shows "the success rate per ISO week with the number of runs" (and the best official
rate of the submissions evaluated that week); the grade sheet gives, per assignment, "how many submissions the
student made". The ISO week is computed here from scratch (the week holding the Thursday of the day's week, the
year that Thursday falls in), not with ``isocalendar``; the count is every submission row of the student for the
assignment, whatever its state (queued, running, done, error) and whether or not it was excluded.
"""

from __future__ import annotations

import datetime as dt
from types import SimpleNamespace
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])


def iso_week(day: dt.date) -> str:
    """``YYYY-Www``: ISO weeks start on Monday; week 1 is the one holding the year's first Thursday."""
    thursday = day + dt.timedelta(days=3 - day.weekday())
    week = (thursday - dt.date(thursday.year, 1, 1)).days // 7 + 1
    return f"{thursday.year}-W{week:02d}"


# instants, most within a week of a new year (where a calendar year and an ISO year part)
instants = st.one_of(
    st.builds(lambda y, d, s: dt.datetime(y, 12, 25, tzinfo=dt.timezone.utc) + dt.timedelta(days=d, seconds=s),
              st.integers(2019, 2030), st.integers(0, 13), st.integers(0, 86399)),
    st.datetimes(min_value=dt.datetime(2024, 1, 1), max_value=dt.datetime(2028, 12, 31),
                 timezones=st.just(dt.timezone.utc)))


@settings(PROPS, max_examples=20)
@given(st.lists(st.tuples(instants, st.booleans()), max_size=12),
       st.lists(st.tuples(instants, st.floats(0, 1)), max_size=5))
def test_each_run_and_evaluated_submission_lands_in_its_iso_week(runs: list[tuple[dt.datetime, bool]],
                                                                  subs: list[tuple[dt.datetime, float]]) -> None:
    from robokit.server.course_pages import weekly_rows

    results = [SimpleNamespace(received_at=t, outcome="succeeded" if ok else "failed") for t, ok in runs]
    submissions = [SimpleNamespace(finished_at=t, success_rate=rate) for t, rate in subs]
    want: dict[str, dict[str, Any]] = {}
    for t, ok in runs:
        w = want.setdefault(iso_week(t.date()), {"runs": 0, "ok": 0, "official": None})
        w["runs"] += 1
        w["ok"] += ok
    for t, rate in subs:
        w = want.setdefault(iso_week(t.date()), {"runs": 0, "ok": 0, "official": None})
        w["official"] = rate if w["official"] is None else max(w["official"], rate)
    got = weekly_rows(results, submissions)
    assert [r["week"] for r in got] == sorted(want)
    for r in got:
        w = want[r["week"]]
        assert (r["runs"], r["ok"], r["official"]) == (w["runs"], w["ok"], w["official"]), r
        assert r["rate"] == (w["ok"] / w["runs"] if w["runs"] else None), r


STATES = ["queued", "running", "done", "error"]


made_strategy = st.lists(st.tuples(st.sampled_from(["kim", "lee"]), st.sampled_from(["one", "two"]),
                                  st.sampled_from(STATES), st.booleans()), min_size=4, max_size=10)


@settings(PROPS, max_examples=4)
@given(made_strategy)
def test_the_grade_sheet_counts_every_submission_a_student_made(course: Any, made: list[tuple[str, str, str,
                                                                                                 bool]]) -> None:
    _grades(course, made)


@pytest.mark.slow
@settings(PROPS, max_examples=60)
@given(st.lists(st.tuples(st.sampled_from(["kim", "lee"]), st.sampled_from(["one", "two"]),
                          st.sampled_from(STATES), st.booleans()), max_size=10))
def test_many_grade_sheets_count_every_submission_a_student_made(course: Any, made: list[tuple[str, str, str,
                                                                                                 bool]]) -> None:
    _grades(course, made)


def _grades(course: Any, made: list[tuple[str, str, str, bool]]) -> None:
    from course_work import OFFICIAL, make_assignment

    from robokit.server.assignments import Assignment, Submission
    from robokit.server.grades import grade_table

    Submission.objects.all().delete()
    Assignment.objects.all().delete()
    assignments = {name: make_assignment(course.room, name=name) for name in ("one", "two")}
    students = {"kim": course.kim, "lee": course.lee}
    for who, which, state, excluded in made:
        Submission.objects.create(assignment=assignments[which], student=students[who], config_text=OFFICIAL,
                                  status=state, excluded=excluded,
                                  success_rate=0.5 if state == "done" else None)
    head, rows = grade_table(course.room)
    by_name = {row[0]: dict(zip(head, row, strict=True)) for row in rows}
    for who, student in students.items():
        for which in assignments:
            count = sum(1 for w, a, _, _ in made if (w, a) == (who, which))
            assert by_name[student.name][f"{which}: submissions"] == count, (who, which)
