"""A student's learning dashboard against the stored runs and submissions, over generated histories.

docs/server.md ("The boards and the learning dashboard", "Moderation"): per ISO week the student's own runs, how many
succeeded, their success rate, and the best official success rate of the submissions evaluated that week; the most
common failure reasons of runs that did not succeed (an outcome-less post is no failure), numbers replaced by ``N``
so alike reasons count as one; excluded runs and submissions left
out; another student's runs never counted.

Each example stores runs of the student (own and official, succeeded or not, excluded or not, over weeks that cross
a year's end, where an ISO week belongs to the other year), runs of a classmate, and submissions evaluated in
generated weeks. The expected tables are computed here: the ISO week from the date by counting days from the
Monday of week 1 (the week with 4 January), the reasons with every run of digits (and a decimal part) written ``N``.
"""

from __future__ import annotations

import datetime as dt
import html
import re
import uuid
from collections import Counter
from typing import Any

import pytest
from course_helpers import PASSWORD
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=8, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
START = dt.datetime(2026, 12, 24, 8, 0, tzinfo=dt.timezone.utc)  # 2026-W52, W53 and 1-3 January 2027 (2026-W53)
REASONS = ("dropped cube {} at {}.5 s", "max_time {} s reached", "", "collision with wall {}", "lost -{}.25 m")

run = st.fixed_dictionaries({
    "hours": st.integers(0, 24 * 10), "outcome": st.sampled_from(["succeeded", "failed", "aborted", "error", ""]),
    "reason": st.sampled_from(REASONS), "n": st.integers(0, 120), "official": st.booleans(),
    "excluded": st.sampled_from([False, False, False, True]), "mine": st.sampled_from([True, True, True, False])})
submission = st.fixed_dictionaries({
    "hours": st.integers(0, 24 * 10), "rate": st.sampled_from([0.0, 0.25, 0.5, 0.8, 1.0]),
    "status": st.sampled_from(["done", "done", "error", "queued"]), "excluded": st.booleans()})


def iso_week(day: dt.date) -> str:
    """The ISO 8601 week, counted: week 1 is the one with 4 January; weeks start on Monday."""
    for year in (day.year + 1, day.year, day.year - 1):
        jan4 = dt.date(year, 1, 4)
        monday = jan4 - dt.timedelta(days=jan4.weekday())
        if day >= monday:
            return f"{year}-W{(day - monday).days // 7 + 1:02d}"
    raise AssertionError(day)


def grouped(reason: str, outcome: str) -> str:
    return re.sub(r"-?[0-9]+(\.[0-9]+)?", "N", reason.strip()) or outcome


@pytest.fixture
def teacher_client(client: Any, course: Any) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


@PROPS
@given(runs=st.lists(run, min_size=6, max_size=14), subs=st.lists(submission, max_size=5))
@example(runs=[{"hours": h, "outcome": o, "reason": "", "n": 0, "official": off, "excluded": False, "mine": True}
                for h, o, off in [(1, "succeeded", False), (2, "failed", True), (3, "failed", False),
                                  (30, "succeeded", True), (200, "succeeded", False), (201, "", False)]],
         subs=[{"hours": 2, "rate": 0.8, "status": "done", "excluded": False},
               {"hours": 5, "rate": 0.25, "status": "done", "excluded": False}])  # the week's best is not its last
def test_the_dashboards_weeks_and_reasons_are_the_stored_runs(teacher_client: Any, course: Any,
                                                              runs: list[dict[str, Any]],
                                                              subs: list[dict[str, Any]]) -> None:
    from course_work import OFFICIAL, make_assignment

    from robokit.server.models import Assignment, Project, Result, Submission

    Result.objects.all().delete()
    Assignment.objects.all().delete()
    Project.objects.all().delete()
    a = make_assignment(course.room)
    for r in runs:
        who = course.kim if r["mine"] else course.lee
        row = Result.objects.create(
            run_id=uuid.uuid4().hex, classroom=course.room, project=a.project, student=who, student_name=who.name,
            verified=True, official=r["official"], outcome=r["outcome"], excluded=r["excluded"],
            reason=r["reason"].format(r["n"], r["n"] % 7) if r["outcome"] not in ("", "succeeded") else "")
        Result.objects.filter(pk=row.pk).update(received_at=START + dt.timedelta(hours=r["hours"]))
    for s in subs:
        done = s["status"] == "done"
        sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status=s["status"],
                                        excluded=s["excluded"], success_rate=s["rate"] if done else None)
        if done:
            Submission.objects.filter(pk=sub.pk).update(finished_at=START + dt.timedelta(hours=s["hours"]))

    page = teacher_client.get(f"/classes/{course.room.pk}/students/{course.kim.pk}/dashboard/")
    assert page.status_code == 200
    text = page.content.decode()

    weeks: dict[str, dict[str, Any]] = {}
    for r in runs:
        if r["mine"] and not r["official"] and not r["excluded"]:
            w = weeks.setdefault(iso_week((START + dt.timedelta(hours=r["hours"])).date()), {"runs": 0, "ok": 0})
            w["runs"] += 1
            w["ok"] += r["outcome"] == "succeeded"
    best: dict[str, float] = {}
    for s in subs:
        if s["status"] == "done" and not s["excluded"]:
            key = iso_week((START + dt.timedelta(hours=s["hours"])).date())
            best[key] = max(best.get(key, 0.0), s["rate"])
    expected = []
    for key in sorted(set(weeks) | set(best)):
        w = weeks.get(key, {"runs": 0, "ok": 0})
        rate = f"{w['ok'] / w['runs']:.2f}" if w["runs"] else "—"
        expected.append((key, str(w["runs"]), str(w["ok"]), rate, f"{best[key]:.2f}" if key in best else "—"))
    table = text.split('id="weeks"')[1].split("</table>")[0]
    got = re.findall(r'<tr><td>(\d{4}-W\d\d)</td><td class="num">(\d+)</td><td class="num">(\d+)</td>'
                     r'<td class="num">(.*?)</td><td class="num">(.*?)</td></tr>', table)
    assert got == expected

    counted = Counter(grouped(r["reason"].format(r["n"], r["n"] % 7), r["outcome"]) for r in runs
                      if r["mine"] and not r["excluded"] and r["outcome"] not in ("", "succeeded"))
    table = text.split('id="reasons"')[1].split("</table>")[0]
    shown = [(html.unescape(k), int(n)) for k, n in
             re.findall(r'<tr><td>(.*?)</td><td class="num">(\d+)</td></tr>', table)]
    assert sorted(shown) == sorted(counted.items())  # at most 5 distinct reasons and 3 outcomes: all shown
    assert [n for _, n in shown] == sorted((n for _, n in shown), reverse=True)  # most common first
    assert f"{sum(w['runs'] for w in weeks.values())} own run" in text



def test_the_weekly_chart_draws_the_tables_figures(teacher_client: Any, course: Any) -> None:
    """The weekly chart is drawn from the same figures as the dashboard's table: the student's own runs (official
    trials and excluded runs left out) and the best evaluated submission per week. Its bytes are the chart of the
    weeks counted here (charts are made deterministically), for a history with an official trial and an excluded
    run in a week of own runs, and two evaluated submissions in one week, the later one lower."""
    from course_work import OFFICIAL, make_assignment

    from robokit.server import charts
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room)
    for hours, outcome, official, excluded in [(1, "succeeded", False, False), (2, "failed", True, False),
                                               (3, "failed", False, False), (4, "succeeded", False, True),
                                               (200, "succeeded", False, False)]:
        row = Result.objects.create(run_id=uuid.uuid4().hex, classroom=course.room, project=a.project,
                                    student=course.kim, student_name=course.kim.name, verified=True,
                                    official=official, outcome=outcome, excluded=excluded)
        Result.objects.filter(pk=row.pk).update(received_at=START + dt.timedelta(hours=hours))
    for hours, rate in [(2, 0.8), (5, 0.25)]:
        sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done",
                                        success_rate=rate)
        Submission.objects.filter(pk=sub.pk).update(finished_at=START + dt.timedelta(hours=hours))
    weeks = [iso_week(START.date()), iso_week((START + dt.timedelta(hours=200)).date())]
    assert weeks == ["2026-W52", "2026-W53"]
    chart = teacher_client.get(f"/classes/{course.room.pk}/students/{course.kim.pk}/weekly.svg")
    assert chart.status_code == 200
    assert chart.content == charts.weekly(f"{course.kim.name}: 주간 성공률", weeks, [1 / 2, 1.0], [2, 1], [0.8, None])
