"""The grades, the official board and "who has submitted" against the stored submissions, over generated classes.

docs/server.md ("Export grades", "The boards and the learning dashboard"): one row per student and, per assignment,
the best official result by the assignment's ranking -- excluded and not yet graded submissions left out -- with its
success rate, Wilson bounds, submission time and late flag, and how many submissions the student made; the CSV with
formula-like text prefixed with ``'``, the workbook with rates as numbers and times as UTC times; the assignment page's
board ranks each student's best, and its "who has submitted" table counts every submission and shows the last one.

Each example stores a generated class: students (one named like a formula), two or three assignments with generated
rankings and due times, and per student and assignment up to four submissions of any state, late or not, excluded
or not, with generated trial counts and a figure. Every expected cell is computed here from what was generated:
the best by a chain of stable sorts (the ranking's last key first, a missing figure last), the rate by counting, the
Wilson bounds as the roots of the score equation.
"""

from __future__ import annotations

import contextlib
import csv
import datetime as dt
import html
import io
import os
import re
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from course_helpers import PASSWORD
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=8, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
Z = 1.959963984540054
T0 = dt.datetime(2026, 11, 2, 9, 0, tzinfo=dt.timezone.utc)
NAMES = ("김민준", "=1+1", "ana", "Bo", "-2")
RANKINGS = ("-success_rate,-wilson_low", "success_rate", "-drop_m,-success_rate", "wilson_high,-wilson_low", "drop_m")
STATES = ("done", "done", "done", "queued", "running", "error")


def wilson(k: int, n: int) -> tuple[float, float]:
    """The p where (k/n - p)^2 = z^2 p (1 - p) / n: the roots of that quadratic."""
    roots = np.roots([1 + Z * Z / n, -(2 * k / n + Z * Z / n), (k / n) ** 2]).real
    return float(min(roots)), float(max(roots))


submission = st.fixed_dictionaries({
    "status": st.sampled_from(STATES), "excluded": st.booleans(), "late": st.booleans(),
    "trials": st.integers(1, 6), "ok": st.integers(0, 6), "minute": st.integers(0, 5000),
    "drop_m": st.one_of(st.none(), st.sampled_from([0.1, 0.25, 0.5, 0.75]))})
classes = st.fixed_dictionaries({
    "students": st.lists(st.sampled_from(NAMES), min_size=1, max_size=4, unique=True),
    "assignments": st.lists(st.tuples(st.sampled_from(RANKINGS), st.integers(0, 30)), min_size=1, max_size=3,
                            unique_by=lambda a: a[1]),
    "work": st.lists(st.lists(submission, max_size=4), min_size=12, max_size=12)})


def ranked(subs: list[dict[str, Any]], ranking: str) -> list[dict[str, Any]]:
    """Best first by the ranking: stable sorts from the last key to the first, ties to the earlier submission."""
    out = sorted(subs, key=lambda s: (s["at"], s["pk"]))
    for part in reversed([p.strip() for p in ranking.split(",") if p.strip()]):
        name, higher = part.lstrip("-+"), part.startswith("-")
        present = [s for s in out if s["figures"].get(name) is not None]
        missing = [s for s in out if s["figures"].get(name) is None]
        present.sort(key=lambda s: s["figures"][name], reverse=higher)  # stable also when reversed
        out = present + missing
    return out


def safe(text: str) -> str:
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text


@contextlib.contextmanager
def local_time(zone: str) -> Iterator[None]:
    """The process's local time zone set to ``zone`` for a while (``TZ`` and ``time.tzset``)."""
    was = os.environ.get("TZ")
    os.environ["TZ"] = zone
    time.tzset()
    try:
        yield
    finally:
        if was is None:
            del os.environ["TZ"]
        else:
            os.environ["TZ"] = was
        time.tzset()


@pytest.fixture
def teacher_client(client: Any, course: Any) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


def store(course: Any, drawn: dict[str, Any]) -> tuple[list[Any], list[Any], dict[tuple[int, int], list[dict]]]:
    """The generated class in the database; what was stored, as plain dicts keyed (assignment, student)."""
    from course_work import OFFICIAL

    from robokit.server.models import Assignment, Project, Student, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    Student.objects.filter(classroom=course.room).delete()
    students = [Student.objects.create(classroom=course.room, name=n) for n in drawn["students"]]
    assignments = []
    for i, (ranking, day) in enumerate(drawn["assignments"]):
        name = f"과제 {i}"
        project = Project.objects.create(classroom=course.room, name=name)
        assignments.append(Assignment.objects.create(
            classroom=course.room, project=project, name=name, kind="drop_test", config_text=OFFICIAL, seeds=[0],
            ranking=ranking, due_at=T0 + dt.timedelta(days=day)))
    stored: dict[tuple[int, int], list[dict]] = {}
    cells = iter(drawn["work"])
    for a in assignments:
        for s in students:
            mine = stored.setdefault((a.pk, s.pk), [])
            for g in next(cells):
                n, k = g["trials"], min(g["ok"], g["trials"])
                done = g["status"] == "done"
                lo, hi = wilson(k, n)
                at = T0 + dt.timedelta(minutes=g["minute"], microseconds=len(mine) * 1000 + 7)
                fig = {"success_rate": k / n if done else None, "wilson_low": lo if done else None,
                       "wilson_high": hi if done else None}
                summary = {}
                if done and g["drop_m"] is not None:
                    summary = {"cells": [{"figures": {"drop_m": {"median": g["drop_m"]}}}]}
                    fig["drop_m"] = g["drop_m"]
                sub = Submission.objects.create(
                    assignment=a, student=s, config_text=OFFICIAL, status=g["status"], excluded=g["excluded"],
                    late=g["late"], trials=n if done else 0, succeeded=k if done else 0, summary=summary,
                    success_rate=fig["success_rate"], wilson_low=fig["wilson_low"], wilson_high=fig["wilson_high"])
                Submission.objects.filter(pk=sub.pk).update(submitted_at=at)
                mine.append({"pk": sub.pk, "at": at, "figures": fig, "k": k, "n": n, **g})
    return students, assignments, stored


def best_of(subs: list[dict], ranking: str) -> dict | None:
    graded = [s for s in subs if s["status"] == "done" and not s["excluded"]]
    return ranked(graded, ranking)[0] if graded else None


@PROPS
@given(classes)
def test_grades_board_and_who_submitted_are_the_stored_submissions(teacher_client: Any, course: Any,
                                                                   drawn: dict[str, Any]) -> None:
    from openpyxl import load_workbook

    students, assignments, stored = store(course, drawn)
    by_due = sorted(assignments, key=lambda a: a.due_at)

    # the CSV: a header per assignment in due order, one row per student, every cell recomputed
    got = teacher_client.get(f"/classes/{course.room.pk}/grades.csv")
    assert got.status_code == 200 and got.content.startswith("\ufeff".encode())
    table = list(csv.reader(io.StringIO(got.content.decode("utf-8-sig"))))
    cols = ("success_rate", "wilson_low", "wilson_high", "submitted_at", "late", "submissions")
    assert table[0] == ["student"] + [f"{a.name}: {c}" for a in by_due for c in cols]
    assert sorted(r[0] for r in table[1:]) == sorted(safe(s.name) for s in students)
    with local_time("Asia/Seoul"):  # a server whose clock is set to Korea: the workbook's times stay UTC
        book = load_workbook(io.BytesIO(teacher_client.get(f"/classes/{course.room.pk}/grades.xlsx").content))
    sheet = list(book["grades"].iter_rows(values_only=True))
    ws = book["grades"]
    assert ws.freeze_panes == "B2" and all(c.font.bold for c in ws[1])  # the header frozen (and bold)
    for cells_ in ws.iter_rows(min_row=2):
        for c in cells_:
            if isinstance(c.value, float):
                assert c.number_format == "0.0000"  # rates shown as in the CSV
            if isinstance(c.value, dt.datetime):
                assert c.is_date and "hh:mm:ss" in c.number_format  # a time, to the second
    assert list(sheet[0]) == table[0] and len(sheet) == len(table)
    by_csv = {r[0]: r for r in table[1:]}
    by_xlsx = {r[0]: r for r in sheet[1:]}
    for s in students:
        row, cells = by_csv[safe(s.name)], by_xlsx[s.name]
        assert book["grades"].cell(row=sheet.index(cells) + 1, column=1).data_type == "s"  # text, never a formula
        for i, a in enumerate(by_due):
            mine = stored[(a.pk, s.pk)]
            best = best_of(mine, a.ranking)
            text, typed = row[1 + 6 * i: 7 + 6 * i], cells[1 + 6 * i: 7 + 6 * i]
            assert text[5] == str(len(mine)) and typed[5] == len(mine)  # every submission counts, any state
            if best is None:
                assert text[:5] == ["", "", "", "", ""] and list(typed[:5]) == [None] * 5
                continue
            lo, hi = wilson(best["k"], best["n"])
            assert text[:3] == [f"{best['k'] / best['n']:.4f}", f"{lo:.4f}", f"{hi:.4f}"]
            assert typed[:3] == pytest.approx((best["k"] / best["n"], lo, hi), abs=1e-9)
            assert dt.datetime.fromisoformat(text[3]) == best["at"]
            assert abs(typed[3] - best["at"].replace(tzinfo=None)) <= dt.timedelta(milliseconds=1)
            assert (text[4], typed[4]) == (("late", "late") if best["late"] else ("", None))

    # each assignment's page: the official board best first, and who has submitted
    for a in assignments:
        page = teacher_client.get(f"/classes/{course.room.pk}/assignments/{a.pk}/").content.decode()
        board_html = page.split('id="official-board"')[1].split("</section>")[0]
        rows = re.findall(r'<td class="student"><a [^>]*>(.*?)</a></td>.*?<td class="num">(\d+)/(\d+)</td>',
                          board_html, re.S)
        bests = [(s, best_of(stored[(a.pk, s.pk)], a.ranking)) for s in students]
        expected = ranked([{**b, "name": s.name} for s, b in bests if b], a.ranking)
        assert [(html.unescape(n), int(k), int(t)) for n, k, t in rows] == [
            (b["name"], b["k"], b["n"]) for b in expected]
        who = page.split('id="who"')[1]
        seen = {html.unescape(n): (int(c), state, "late" in tail) for n, c, state, tail in re.findall(
            r'<tr class="(?:missing)?"><td><a [^>]*>(.*?)</a></td><td class="num">(\d+)</td>\s*<td>.*?</td>\s*'
            r'<td>(.*?)</td><td>(.*?)</td></tr>', who, re.S)}
        for s in students:
            mine = stored[(a.pk, s.pk)]
            last = max(mine, key=lambda x: (x["at"], x["pk"]))["status"] if mine else "not submitted"
            assert seen[s.name] == (len(mine), last, any(x["late"] for x in mine)), s.name
