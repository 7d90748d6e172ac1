"""The teacher's pages (class, leaderboard, student history, run, CSV) and a student's own page.

Teachers log in with their Django account and see the classes they own (a superuser sees every class). A
student opens ``/me/`` and pastes their token once; the session then shows only their own runs. Templates
escape every name (Django autoescaping), so names in Korean or names made of HTML show as the text they are.
"""

from __future__ import annotations

import csv
import json
import mimetypes
import re
from pathlib import Path
from typing import Any

from django.conf import settings
from django.contrib.auth.decorators import login_required
from django.db.models import Count, Max
from django.http import FileResponse, Http404, HttpRequest, HttpResponse, HttpResponseRedirect
from django.shortcuts import get_object_or_404, render
from django.urls import reverse
from django.views.decorators.http import require_http_methods

from robokit.server import tokens
from robokit.server.models import Artifact, Classroom, Project, Result, Student, Token
from robokit.server.payload import config_name
from robokit.server.ranking import best_per_student, columns
from robokit.server.replay_page import replay_context
from robokit.server.submitted import scrub

SESSION_TOKEN = "course_student_token"


def _classes_of(user: Any) -> Any:
    return Classroom.objects.all() if user.is_superuser else Classroom.objects.filter(owner=user)


def _teacher_class(request: HttpRequest, pk: int) -> Classroom:
    return get_object_or_404(_classes_of(request.user), pk=pk)


def session_student(request: HttpRequest) -> Student | None:
    """The student whose token signed this browser in, while that token is still active."""
    token_id = request.session.get(SESSION_TOKEN)
    if token_id is None:
        return None
    row = Token.objects.select_related("student", "classroom").filter(
        pk=token_id, kind=Token.STUDENT, revoked_at__isnull=True).first()
    if row is None:
        request.session.pop(SESSION_TOKEN, None)
        return None
    return row.student


def home(request: HttpRequest) -> HttpResponse:
    if request.user.is_authenticated:
        classes = _classes_of(request.user).annotate(n_students=Count("students", distinct=True),
                                                     n_results=Count("results", distinct=True))
        return render(request, "course/home.html", {"classes": classes})
    if session_student(request) is not None:
        return HttpResponseRedirect(reverse("me"))
    return render(request, "course/welcome.html")


@login_required
def classroom(request: HttpRequest, pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    projects = (Project.objects.filter(classroom=room)
                .annotate(n=Count("results"), last=Max("results__received_at")).order_by("name"))
    students = room.students.annotate(n=Count("results"), last=Max("results__received_at"))
    active = set(Token.objects.filter(classroom=room, kind=Token.STUDENT, revoked_at__isnull=True)
                 .values_list("student_id", flat=True))
    rows = [{"student": s, "n": s.n, "last": s.last, "token": s.pk in active} for s in students]
    api_url = request.build_absolute_uri(reverse("api-result"))
    assignments = room.assignments.annotate(n=Count("submissions"))
    return render(request, "course/classroom.html", {"room": room, "projects": projects, "students": rows,
                                                     "api_url": api_url, "assignments": assignments})


def _figure_order(request: HttpRequest, cols: list[str], ranking: list[tuple[str, bool]]) -> tuple[str, bool]:
    """The column the table is sorted by and whether higher comes first (from ?sort= and ?order=)."""
    sort = request.GET.get("sort", "")
    if sort not in cols:
        return "", False
    default_high = dict(ranking).get(sort, sort.endswith(("_sorted", "_total", "collected")))
    order = request.GET.get("order")
    return sort, (order == "desc") if order in ("asc", "desc") else default_high


@login_required
def leaderboard(request: HttpRequest, pk: int, project_pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    project = get_object_or_404(Project, pk=project_pk, classroom=room)
    runs = list(Result.objects.filter(classroom=room, project=project, excluded=False).select_related("student"))
    ranking = project.ranking_keys()
    cols = columns(ranking, (r.figures for r in runs))
    sort, high = _figure_order(request, cols, ranking)
    keys = ([(sort, high)] if sort else []) + [k for k in ranking if k[0] != sort]
    sections = [
        ("students", "Students' runs (verified by their token)", [r for r in runs if r.verified and not r.official]),
        ("official", "Official runs (posted with the teacher's token)", [r for r in runs if r.official]),
        ("unverified", "Posted without a token (unverified)", [r for r in runs if not r.verified]),
    ]
    tables = [{"id": sid, "title": title, "rows": _rows(best_per_student(rs, keys), cols), "n_runs": len(rs)}
              for sid, title, rs in sections if rs or sid == "students"]
    headers = [{"name": c, "sorted": c == sort, "high": high if c == sort else None,
                "next": "asc" if c == sort and high else "desc"} for c in cols]
    return render(request, "course/leaderboard.html", {
        "room": room, "project": project, "tables": tables, "headers": headers, "sort": sort,
        "ranking": project.ranking or "(none)"})


def _rows(results: list[Result], cols: list[str]) -> list[dict[str, Any]]:
    return [{"rank": i, "r": r, "figures": [_fmt(r.figures.get(c)) for c in cols]} for i, r in enumerate(results, 1)]


def _fmt(value: Any) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.4g}" if abs(value) < 1e4 else f"{value:.0f}"
    return str(value)


@login_required
def student_history(request: HttpRequest, pk: int, student_pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    student = get_object_or_404(Student, pk=student_pk, classroom=room)
    runs = Result.objects.filter(student=student).select_related("project")
    return render(request, "course/history.html", {"room": room, "student": student, "runs": _history(runs)})


def _history(runs: Any) -> list[dict[str, Any]]:
    return [{"r": r, "figures": ", ".join(f"{k} {_fmt(v)}" for k, v in list(r.figures.items())[:6])} for r in runs]


def _may_view(request: HttpRequest, record: Result) -> bool:
    user = request.user
    if user.is_authenticated and (user.is_superuser or record.classroom.owner_id == user.pk):
        return True
    student = session_student(request)
    return (student is not None and record.verified and not record.official
            and record.student_id == student.pk)


def run_detail(request: HttpRequest, run_id: str) -> HttpResponse:
    record = get_object_or_404(Result.objects.select_related("classroom", "project", "student"), run_id=run_id)
    if not _may_view(request, record):
        if not request.user.is_authenticated and session_student(request) is None:
            return HttpResponseRedirect(f"{reverse('login')}?next={request.path}")
        raise Http404("no such run")
    artifacts = list(record.artifacts.all())
    result = record.payload.get("result") if isinstance(record.payload.get("result"), dict) else {}
    trace = next((a for a in artifacts if a.kind == Artifact.TRACE), None)
    config = next((a for a in artifacts if a.kind == Artifact.CONFIG), None)
    payload = dict(record.payload)
    if isinstance(payload.get("config"), str):  # rows stored before the server kept only the file name
        payload["config"] = config_name(payload["config"])
    replay = next((a for a in artifacts if a.kind == Artifact.REPLAY), None)
    return render(request, "course/run.html", {**replay_context(replay),
        "r": record, "config_name": config_name(record.config),
        "figures": [(k, _fmt(v)) for k, v in record.figures.items()],
        "objects": _objects_table(result.get("objects")),
        "videos": [a for a in artifacts if a.kind == Artifact.VIDEO],
        "plots": [a for a in artifacts if a.kind == Artifact.PLOT],
        "timeline": _timeline(trace, record.sim_time or record.total_time) if trace else None,
        "config_text": _read_text(config) if config else None,
        "payload": scrub(json.dumps(payload, indent=2, ensure_ascii=False)[:20000]),
        "teacher": request.user.is_authenticated,
    })


def _objects_table(objects: Any) -> dict[str, Any] | None:
    if not isinstance(objects, list) or not objects or not all(isinstance(o, dict) for o in objects):
        return None
    cols: list[str] = []
    for o in objects:
        cols += [k for k in o if k not in cols]
    cells = [[_cell(o.get(c)) for c in cols] for o in objects[:200]]
    return {"cols": cols, "rows": cells}


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return _fmt(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value, ensure_ascii=False)[:80]
    return "" if value is None else str(value)


def _read_text(artifact: Artifact, limit: int = 200_000) -> str:
    path = Path(settings.MEDIA_ROOT) / artifact.path
    try:
        return path.read_bytes()[:limit].decode("utf-8", "replace")
    except OSError:
        return ""


def _timeline(trace: Artifact, end_time: float | None) -> dict[str, Any]:
    """State transitions from an uploaded trace: a table, and per machine a bar of its states over sim time."""
    transitions = []
    for line in _read_text(trace, settings.MAX_TRACE_BYTES).splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if isinstance(rec, dict) and rec.get("kind") == "transition" and isinstance(rec.get("t"), (int, float)):
            transitions.append(rec)
    end = max([end_time or 0.0] + [float(t["t"]) for t in transitions]) or 1.0
    bars: dict[str, list[dict[str, Any]]] = {}
    for t in transitions:
        segs = bars.setdefault(str(t.get("machine", "")), [])
        if not segs and float(t["t"]) > 0:  # the state it was in before: the bar starts at 0 like every other
            segs.append({"state": str(t.get("source_state", "")), "start": 0.0, "end": end})
        if segs:
            segs[-1]["end"] = float(t["t"])
        segs.append({"state": str(t.get("dest_state", "")), "start": float(t["t"]), "end": end})
    palette: dict[str, int] = {}
    for segs in bars.values():
        for s in segs:
            s["width"] = round(max(s["end"] - s["start"], 0.0) / end * 100, 3)
            s["colour"] = palette.setdefault(s["state"], len(palette) % 10)
    return {"rows": transitions[:500], "bars": bars, "end": end, "more": max(len(transitions) - 500, 0)}


_CSV_FORMULA = re.compile(r"^[=+\-@\t\r]")


def _csv_safe(value: Any) -> Any:
    """Spreadsheet-safe text: a cell starting with = + - @ is prefixed with ' (CSV injection)."""
    if isinstance(value, str) and _CSV_FORMULA.match(value):
        return "'" + value
    return value


@login_required
def export_csv(request: HttpRequest, pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    response = HttpResponse(content_type="text/csv; charset=utf-8")
    response["Content-Disposition"] = f'attachment; filename="results-class-{room.pk}.csv"'
    response.write("\ufeff")  # a BOM, so spreadsheet programs read Korean names as UTF-8
    writer = csv.writer(response)
    fields = ["run_id", "received_at", "class", "project", "student", "posted_student", "verified", "official",
              "outcome", "red_sorted", "blue_sorted", "failures", "total_time", "sim_time", "seed", "behaviour",
              "config", "figures"]
    writer.writerow(fields)
    runs = Result.objects.filter(classroom=room).select_related("project").order_by("received_at", "id")
    for r in runs.iterator():
        row = [r.run_id, r.received_at.isoformat(), room.name, r.project.name, r.student_name, r.posted_student,
               r.verified, r.official, r.outcome, r.red_sorted, r.blue_sorted, r.failures, r.total_time,
               r.sim_time, r.seed, r.behaviour, config_name(r.config), json.dumps(r.figures, ensure_ascii=False)]
        writer.writerow([_csv_safe(v) for v in row])
    return response


def artifact_file(request: HttpRequest, pk: int, name: str) -> HttpResponse:
    """An uploaded file, to whoever may see its run; byte ranges for video seeking; SVG sandboxed."""
    artifact = get_object_or_404(Artifact.objects.select_related("result__classroom"), pk=pk, name=name)
    if not _may_view(request, artifact.result):
        raise Http404("no such file")
    path = Path(settings.MEDIA_ROOT) / artifact.path
    if not path.is_file():
        raise Http404("file missing")
    response = _ranged(request, path, artifact.content_type or mimetypes.guess_type(name)[0] or "")
    response["Content-Security-Policy"] = "default-src 'none'; style-src 'unsafe-inline'; sandbox"
    response["Cache-Control"] = "private, max-age=3600"
    return response


_RANGE = re.compile(r"^bytes=(\d*)-(\d*)$")


def _ranged(request: HttpRequest, path: Path, content_type: str) -> HttpResponse:
    size = path.stat().st_size
    match = _RANGE.match(request.headers.get("Range", ""))
    if not match or not (match.group(1) or match.group(2)):
        response = FileResponse(path.open("rb"), content_type=content_type)
        response["Accept-Ranges"] = "bytes"
        return response
    first, last = match.groups()
    start = int(first) if first else max(size - int(last), 0)
    end = min(int(last), size - 1) if first and last else size - 1
    if start >= size or start > end:
        response = HttpResponse(status=416)
        response["Content-Range"] = f"bytes */{size}"
        return response
    with path.open("rb") as fh:
        fh.seek(start)
        data = fh.read(end - start + 1)
    response = HttpResponse(data, status=206, content_type=content_type)
    response["Content-Range"] = f"bytes {start}-{end}/{size}"
    response["Accept-Ranges"] = "bytes"
    return response


@require_http_methods(["GET", "POST"])
def me(request: HttpRequest) -> HttpResponse:
    """A student's own runs. POST a token to open the page; the token is checked, never shown or stored."""
    error = ""
    if request.method == "POST":
        raw = request.POST.get("token", "").strip()
        try:
            row = tokens.find(raw) if raw else None
        except tokens.TokenError as exc:
            row, error = None, str(exc)
        if row is not None and row.kind == Token.STUDENT:
            request.session.cycle_key()
            request.session[SESSION_TOKEN] = row.pk
            return HttpResponseRedirect(reverse("me"))
        error = error or "that is not a student token"
    student = session_student(request)
    if student is None:
        return render(request, "course/me_login.html", {"error": error}, status=401 if error else 200)
    runs = (Result.objects.filter(student=student, verified=True, official=False)
            .select_related("project"))
    subs = list(student.submissions.select_related("assignment")[:100])
    trials: dict[int, list[Result]] = {}
    for r in Result.objects.filter(submission__in=subs, official=True).order_by("seed"):
        trials.setdefault(r.submission_id or 0, []).append(r)
    mine = [{"s": s, "trials": trials.get(s.pk, [])} for s in subs]
    return render(request, "course/me.html", {"student": student, "runs": _history(runs), "subs": mine,
                                              "training": list(student.training_runs.all()[:20])})


@require_http_methods(["POST"])
def me_logout(request: HttpRequest) -> HttpResponse:
    request.session.pop(SESSION_TOKEN, None)
    return HttpResponseRedirect(reverse("home"))


