"""Grades: one row per student and, per assignment, the best official result (success rate and its Wilson bounds),
when that submission was made, whether it was late, and how many submissions the student made. As CSV (UTF-8 with a
BOM, so spreadsheet programs read Korean names) or as an Excel workbook written by openpyxl (numbers as numbers,
times as times in UTC).

Text a spreadsheet would run as a formula (a name starting with ``=``, ``+``, ``-``, ``@``) is kept as text: in the
CSV with a leading ``'``, in the workbook as a string cell.
"""

from __future__ import annotations

import datetime as dt
import io
from collections import Counter
from typing import Any

from django.contrib.auth.decorators import login_required
from django.http import HttpRequest, HttpResponse
from django.urls import path

from robokit.server.assignments import Submission
from robokit.server.course_pages import best_submissions
from robokit.server.pages import _csv_safe, _teacher_class

COLUMNS = ("success_rate", "wilson_low", "wilson_high", "submitted_at", "late", "submissions")
XLSX = "application/vnd.openxmlformats-officedocument.spreadsheetml.sheet"


def grade_table(room: Any) -> tuple[list[str], list[list[Any]]]:
    """The header and one row per student (by name): values typed (float or None, a UTC datetime or None, bool,
    int)."""
    assignments = list(room.assignments.order_by("due_at", "name"))
    best = {a.pk: {s.student_id: s for s in best_submissions(a)} for a in assignments}
    counts = Counter((s.assignment_id, s.student_id) for s in Submission.objects.filter(assignment__classroom=room))
    head = ["student"] + [f"{a.name}: {c}" for a in assignments for c in COLUMNS]
    rows = []
    for st in room.students.order_by("name"):
        row: list[Any] = [st.name]
        for a in assignments:
            sub = best[a.pk].get(st.pk)
            row += ([sub.success_rate, sub.wilson_low, sub.wilson_high, sub.submitted_at, sub.late]
                    if sub else [None, None, None, None, False]) + [counts[(a.pk, st.pk)]]
        rows.append(row)
    return head, rows


def _text(value: Any) -> Any:
    """A CSV cell: rates with 4 decimals, times in ISO 8601, ``late`` or nothing."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "late" if value else ""
    if isinstance(value, float):
        return f"{value:.4f}"
    if isinstance(value, dt.datetime):
        return value.isoformat()
    return _csv_safe(value)


@login_required
def grades_csv(request: HttpRequest, pk: int) -> HttpResponse:
    import csv

    room = _teacher_class(request, pk)
    head, rows = grade_table(room)
    response = HttpResponse(content_type="text/csv; charset=utf-8")
    response["Content-Disposition"] = f'attachment; filename="grades-class-{room.pk}.csv"'
    response.write("\ufeff")
    writer = csv.writer(response)
    writer.writerow([_csv_safe(h) for h in head])
    for row in rows:
        writer.writerow([_text(v) for v in row])
    return response


def _cell_value(value: Any) -> Any:
    """A workbook cell: times as naive UTC datetimes (Excel has no time zones), ``late`` as text."""
    if isinstance(value, bool):
        return "late" if value else None
    if isinstance(value, dt.datetime):
        return value.astimezone(dt.timezone.utc).replace(tzinfo=None)
    return value


def workbook(room: Any) -> bytes:
    """The grades as an .xlsx file (one sheet, header bold and frozen)."""
    from openpyxl import Workbook
    from openpyxl.styles import Font

    head, rows = grade_table(room)
    book = Workbook()
    sheet = book.active
    sheet.title = "grades"
    for r, values in enumerate([head, *rows], 1):
        for c, value in enumerate(values, 1):
            cell = sheet.cell(row=r, column=c, value=_cell_value(value))
            if cell.data_type == "f":  # a name like "=1+1" stays text, never a formula
                cell.data_type = "s"
            if r == 1:
                cell.font = Font(bold=True)
            elif isinstance(cell.value, float):
                cell.number_format = "0.0000"
            elif isinstance(cell.value, dt.datetime):
                cell.number_format = "yyyy-mm-dd hh:mm:ss"
    sheet.freeze_panes = "B2"
    sheet.column_dimensions["A"].width = 18
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


@login_required
def grades_xlsx(request: HttpRequest, pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    response = HttpResponse(workbook(room), content_type=XLSX)
    response["Content-Disposition"] = f'attachment; filename="grades-class-{room.pk}.xlsx"'
    return response


urlpatterns = [
    path("classes/<int:pk>/grades.csv", grades_csv, name="grades-csv"),
    path("classes/<int:pk>/grades.xlsx", grades_xlsx, name="grades-xlsx"),
]
