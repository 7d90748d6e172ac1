"""Ranking and the grade table's shape, against plain sorts, over generated figures (docs/server.md, "What the teacher
sees", "Export grades", "The boards and the learning dashboard").

Each student's best is their own: a student is their account, or the name posted without a token -- two students
who share a name are two rows. A missing figure ranks after every present one, whichever way the figure ranks. The
grade table's assignments come by due time, then by name; its times are formatted as times in the workbook. The
dashboard lists at most the eight most common failure reasons.
"""

from __future__ import annotations

import datetime as dt
import io
from types import SimpleNamespace
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.server.course_pages import reason_counts, sub_key
from robokit.server.ranking import best_per_student

pytest_plugins = ["course_fixtures"]

T0 = dt.datetime(2026, 12, 1, 9, 0, tzinfo=dt.timezone.utc)
run = st.tuples(st.sampled_from([(1, "김민준"), (2, "김민준"), (None, "김민준"), (None, "이서연"), (3, "이서연")]),
                st.sampled_from(["succeeded", "failed", ""]), st.one_of(st.none(), st.integers(0, 5)))


@settings(max_examples=30, deadline=None, derandomize=True, database=None)
@given(st.lists(run, min_size=1, max_size=10), st.booleans())
def test_each_owner_has_one_row_its_best(runs: list, higher: bool) -> None:
    """Owners are accounts, or posted names without one: two students named alike are two rows, and neither is the
    tokenless post of that name. The best: successful or outcome-less first, then the figure (a missing one last),
    then the earlier run."""
    results = [SimpleNamespace(pk=i + 1, student_id=sid, student_name=name, outcome=outcome,
                               figures={} if v is None else {"score": v}, received_at=T0 + dt.timedelta(minutes=i))
               for i, ((sid, name), outcome, v) in enumerate(runs)]
    owners: dict[Any, list] = {}
    for r in results:
        owners.setdefault(r.student_id if r.student_id is not None else f"name:{r.student_name}", []).append(r)

    def plain(r: Any) -> tuple:
        v = r.figures.get("score")
        return (r.outcome not in ("", "succeeded"), v is None, 0 if v is None else (-v if higher else v),
                r.received_at)

    best = [min(rs, key=plain) for rs in owners.values()]
    got = best_per_student(results, [("score", higher)])
    assert [r.pk for r in got] == [r.pk for r in sorted(best, key=plain)]


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.lists(st.one_of(st.none(), st.sampled_from([0, 0.5, 1.0, -2.0])), min_size=2, max_size=6), st.booleans())
def test_a_submission_missing_the_ranked_figure_ranks_after_every_one_that_has_it(values: list, higher: bool) -> None:
    subs = [SimpleNamespace(pk=i + 1, figures={} if v is None else {"time": v},
                            submitted_at=T0 + dt.timedelta(minutes=i)) for i, v in enumerate(values)]
    ranked = sorted(subs, key=lambda s: sub_key(s, [("time", higher)]))
    present = [s for s in subs if "time" in s.figures]
    expected = sorted(present, key=lambda s: (-s.figures["time"] if higher else s.figures["time"], s.submitted_at))
    assert [s.pk for s in ranked] == [s.pk for s in expected] + [s.pk for s in subs if "time" not in s.figures]


def test_the_dashboard_lists_the_eight_most_common_reasons() -> None:
    counts = {f"reason {chr(65 + i)}": 12 - i for i in range(11)}  # 11 distinct reasons, 12 down to 2 runs
    results = [SimpleNamespace(outcome="failed", reason=reason) for reason, n in counts.items() for _ in range(n)]
    assert reason_counts(results) == list(counts.items())[:8]


def test_the_grade_tables_assignments_come_by_due_time_then_name_and_its_times_are_times(course: Any) -> None:
    from course_work import make_assignment
    from openpyxl import load_workbook

    from robokit.server.grades import COLUMNS, grade_table, workbook
    from robokit.server.models import Submission

    due = T0 + dt.timedelta(days=3)
    for name, when in [("다", due), ("나", due), ("가", due + dt.timedelta(days=1)), ("라", None)]:
        make_assignment(course.room, name=name, due_at=when)
    head, rows = grade_table(course.room)
    names = sorted([("다", due), ("나", due), ("가", due + dt.timedelta(days=1))], key=lambda x: (x[1], x[0]))
    order = [n for n, _ in names] + ["라"]  # no due time: after every due one, as the database sorts NULL last
    if head[1].startswith("라"):  # SQLite sorts NULL first
        order = ["라"] + order[:-1]
    assert head == ["student"] + [f"{n}: {c}" for n in order for c in COLUMNS]
    a = course.room.assignments.get(name="나")
    sub = Submission.objects.create(assignment=a, student=course.kim, config_text="", status="done",
                                    success_rate=0.5, wilson_low=0.1, wilson_high=0.9)
    sheet = load_workbook(io.BytesIO(workbook(course.room))).active
    at = head.index("나: submitted_at") + 1
    row = next(r for r in range(2, sheet.max_row + 1) if sheet.cell(row=r, column=1).value == course.kim.name)
    cell = sheet.cell(row=row, column=at)
    utc = sub.submitted_at.astimezone(dt.timezone.utc).replace(tzinfo=None)
    assert abs(cell.value - utc) < dt.timedelta(milliseconds=1)  # Excel keeps times to the millisecond
    assert cell.number_format == "yyyy-mm-dd hh:mm:ss" and cell.is_date
