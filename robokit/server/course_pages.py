"""The teacher's course pages: assignments (official board, who has submitted, charts), a student's learning
dashboard, and moderation (exclude a run or a submission, with the log). Grades are in :mod:`robokit.server.grades`."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable, Iterable
from typing import Any

from django.conf import settings
from django.contrib.auth.decorators import login_required
from django.db import transaction
from django.http import Http404, HttpRequest, HttpResponse, HttpResponseRedirect
from django.shortcuts import get_object_or_404, render
from django.urls import path, reverse
from django.views.decorators.http import require_POST
from django_q.tasks import async_task

from robokit.server import charts
from robokit.server.assignments import Assignment, ModerationEvent, Submission, TrainingRun
from robokit.server.evaluation import TASK
from robokit.server.models import Result, Student
from robokit.server.pages import _teacher_class, session_student
from robokit.server.submitted import scrub

NUMBER = re.compile(r"-?\d+(\.\d+)?")


def ranking_keys(assignment: Assignment) -> list[tuple[str, bool]]:
    return [(p.strip().lstrip("-+"), p.strip().startswith("-")) for p in assignment.ranking.split(",") if p.strip()]


def sub_key(sub: Submission, keys: list[tuple[str, bool]]) -> tuple[Any, ...]:
    """Smaller is better: the ranking's figures in order (a missing one last), then the earlier submission."""
    figs = sub.figures
    parts: list[Any] = []
    for name, higher in keys:
        value = figs.get(name)
        parts.append((1, 0) if value is None else (0, -value if higher else value))
    return (*parts, sub.submitted_at, sub.pk)


def best_submissions(assignment: Assignment) -> list[Submission]:
    """Each student's best evaluated submission (excluded ones left out), best first."""
    keys = ranking_keys(assignment)
    best: dict[int, Submission] = {}
    for sub in assignment.submissions.filter(status=Submission.DONE, excluded=False).select_related("student"):
        if sub.student_id not in best or sub_key(sub, keys) < sub_key(best[sub.student_id], keys):
            best[sub.student_id] = sub
    return sorted(best.values(), key=lambda s: sub_key(s, keys))


def reason_counts(results: Iterable[Result], top: int = 8) -> list[tuple[str, int]]:
    """The most common reasons of runs that did not succeed (numbers replaced by N so alike reasons group)."""
    counted = Counter(NUMBER.sub("N", scrub(r.reason.strip())) or r.outcome for r in results
                      if r.outcome not in ("", "succeeded"))
    return counted.most_common(top)


def _assignment(request: HttpRequest, pk: int, apk: int) -> Assignment:
    room = _teacher_class(request, pk)
    return get_object_or_404(Assignment.objects.select_related("classroom", "project"), pk=apk, classroom=room)


@login_required
def assignment_page(request: HttpRequest, pk: int, apk: int) -> HttpResponse:
    a = _assignment(request, pk, apk)
    board = best_submissions(a)
    subs = list(a.submissions.select_related("student"))
    students = []
    for s in a.classroom.students.all():
        mine = [x for x in subs if x.student_id == s.pk]
        students.append({"student": s, "n": len(mine), "last": mine[0] if mine else None,
                         "late": any(x.late for x in mine)})
    status = Counter(x.status for x in subs)
    return render(request, "course/assignment.html", {
        "room": a.classroom, "a": a, "board": [{"rank": i, "s": s} for i, s in enumerate(board, 1)],
        "students": students, "missing": [r["student"] for r in students if not r["n"]],
        "subs": subs[:200], "status": dict(status), "seeds": len(a.seeds)})


def _svg_response(svg: bytes) -> HttpResponse:
    response = HttpResponse(svg, content_type="image/svg+xml")
    response["Content-Security-Policy"] = "default-src 'none'; style-src 'unsafe-inline'; sandbox"
    response["Cache-Control"] = "private, no-cache"
    return response


@login_required
def assignment_chart(request: HttpRequest, pk: int, apk: int, kind: str) -> HttpResponse:
    a = _assignment(request, pk, apk)
    if kind == "distribution":
        rates = [s.success_rate or 0.0 for s in best_submissions(a)]
        return _svg_response(charts.distribution(f"{a.name}: 학생별 최고 공식 성공률", rates,
                                                 "공식 성공률 official success %"))
    if kind == "reasons":
        runs = Result.objects.filter(submission__assignment=a, excluded=False)
        return _svg_response(charts.reasons(f"{a.name}: 실패 이유 failure reasons", reason_counts(runs)))
    raise Http404("no such chart")


def _student(request: HttpRequest, pk: int, spk: int) -> Student:
    room = _teacher_class(request, pk)
    return get_object_or_404(Student.objects.select_related("classroom"), pk=spk, classroom=room)


def _week(when: Any) -> str:
    year, week, _ = when.isocalendar()
    return f"{year}-W{week:02d}"


def weekly_rows(results: Iterable[Result], submissions: Iterable[Submission] = ()) -> list[dict[str, Any]]:
    """Per ISO week: the student's own runs, how many succeeded, their success rate, and the best official
    success rate of the submissions evaluated that week (None without one)."""
    weeks: dict[str, dict[str, Any]] = {}

    def row(key: str) -> dict[str, Any]:
        return weeks.setdefault(key, {"week": key, "runs": 0, "ok": 0, "rate": None, "official": None})

    for r in results:
        w = row(_week(r.received_at))
        w["runs"] += 1
        w["ok"] += r.outcome == "succeeded"
    for sub in submissions:
        if sub.finished_at is not None and sub.success_rate is not None:
            w = row(_week(sub.finished_at))
            w["official"] = max(w["official"] or 0.0, sub.success_rate)
    rows = [weeks[k] for k in sorted(weeks)]
    for w in rows:
        w["rate"] = w["ok"] / w["runs"] if w["runs"] else None
    return rows


@login_required
def student_dashboard(request: HttpRequest, pk: int, spk: int) -> HttpResponse:
    s = _student(request, pk, spk)
    runs = list(Result.objects.filter(student=s, excluded=False).order_by("received_at"))
    own = [r for r in runs if not r.official]
    subs = list(s.submissions.select_related("assignment").order_by("submitted_at"))
    return render(request, "course/dashboard.html", {
        "room": s.classroom, "student": s, "weeks": weekly_rows(own, _evaluated(s)), "subs": subs,
        "reasons": reason_counts(runs), "training": list(TrainingRun.objects.filter(student=s)),
        "n_runs": len(own)})


def _evaluated(s: Student) -> list[Submission]:
    return list(s.submissions.filter(status=Submission.DONE, excluded=False).order_by("finished_at"))


@login_required
def student_chart(request: HttpRequest, pk: int, spk: int, kind: str) -> HttpResponse:
    s = _student(request, pk, spk)
    own = list(Result.objects.filter(student=s, excluded=False, official=False).order_by("received_at"))
    if kind == "timeline":
        official = [(x.finished_at, x.success_rate or 0.0) for x in _evaluated(s) if x.finished_at is not None]
        return _svg_response(charts.timeline(f"{s.name}: 시도와 공식 결과", [r.received_at for r in own], official))
    if kind == "weekly":
        rows = weekly_rows(own, _evaluated(s))
        return _svg_response(charts.weekly(f"{s.name}: 주간 성공률", [w["week"] for w in rows],
                                           [w["rate"] for w in rows], [w["runs"] for w in rows],
                                           [w["official"] for w in rows]))
    if kind == "training":
        return training_chart(s)
    raise Http404("no such chart")


def training_chart(s: Student) -> HttpResponse:
    """The student's last eight training runs: return and success rate over env steps."""
    train = [(t.name or t.run_id[:8], t.points) for t in TrainingRun.objects.filter(student=s)[:8]]
    return _svg_response(charts.training(f"{s.name}: 학습 곡선 training", train))


def my_training_chart(request: HttpRequest) -> HttpResponse:
    """``/me/training.svg``: the same chart for the student whose token opened the session."""
    student = session_student(request)
    if student is None:
        raise Http404("open /me/ with your token first")
    return training_chart(student)


@login_required
def submission_page(request: HttpRequest, pk: int) -> HttpResponse:
    sub = get_object_or_404(Submission.objects.select_related("assignment__classroom", "student"), pk=pk)
    _teacher_class(request, sub.assignment.classroom_id)
    return render(request, "course/submission.html", {
        "room": sub.assignment.classroom, "sub": sub, "a": sub.assignment,
        "trials": list(sub.results.order_by("seed")), "log": list(sub.moderation.all())})


@login_required
@require_POST
def moderate(request: HttpRequest, pk: int) -> HttpResponse:
    """Exclude a run (``run_id``) or a submission (``submission``) from the boards, or put it back; the reason is
    required and kept in the class's moderation log."""
    room = _teacher_class(request, pk)
    action = request.POST.get("action", ModerationEvent.EXCLUDE)
    reason = " ".join(request.POST.get("reason", "").split())[:1000]
    if action not in (ModerationEvent.EXCLUDE, ModerationEvent.INCLUDE) or not reason:
        return HttpResponse("reason: required (say why the run is excluded or put back)", status=400,
                            content_type="text/plain; charset=utf-8")
    excluded = action == ModerationEvent.EXCLUDE
    with transaction.atomic():
        if request.POST.get("submission"):
            sub = get_object_or_404(Submission, pk=request.POST["submission"], assignment__classroom=room)
            Submission.objects.filter(pk=sub.pk).update(excluded=excluded)
            ModerationEvent.objects.create(classroom=room, submission=sub, action=action, reason=reason,
                                           teacher=request.user, what=f"submission {sub}")
            back = reverse("submission", args=[sub.pk])
        else:
            run = get_object_or_404(Result, run_id=request.POST.get("run_id", ""), classroom=room)
            Result.objects.filter(pk=run.pk).update(excluded=excluded)
            ModerationEvent.objects.create(classroom=room, result=run, action=action, reason=reason,
                                           teacher=request.user, what=f"run {run.run_id} of {run.student_name}")
            back = reverse("run", args=[run.run_id])
    return HttpResponseRedirect(back)


@login_required
@require_POST
def reevaluate(request: HttpRequest, pk: int) -> HttpResponse:
    """Evaluate a graded submission again on the official seeds (its official trials replaced); the reason is
    required and kept in the class's moderation log."""
    sub = get_object_or_404(Submission.objects.select_related("assignment__classroom", "student"), pk=pk)
    room = _teacher_class(request, sub.assignment.classroom_id)
    reason = " ".join(request.POST.get("reason", "").split())[:1000]
    if not reason:
        return _plain(400, "reason: required (say why the submission is evaluated again)")
    sync = bool(getattr(settings, "QUEUE_SYNC", False))
    with transaction.atomic():
        again = Submission.objects.filter(pk=sub.pk, status__in=[Submission.DONE, Submission.ERROR]).update(
            status=Submission.QUEUED, claim=None, error="", trials=0, succeeded=0, success_rate=None,
            wilson_low=None, wilson_high=None, summary={}, finished_at=None)
        if not again:
            return _plain(409, f"submission {sub.pk} is {sub.status}: evaluate it again once it is graded")
        Result.objects.filter(submission=sub, official=True).delete()
        event = ModerationEvent.objects.create(classroom=room, submission=sub, action=ModerationEvent.REEVALUATE,
                                               reason=reason, teacher=request.user, what=f"submission {sub}")
        if not sync:  # a ticket of its own (see fair_queue.claim): the submission's first may still be in use
            async_task(TASK, -event.pk, task_name=f"evaluate submission {sub.pk} again")
    if sync:
        async_task(TASK, sub.pk, sync=True, task_name=f"evaluate submission {sub.pk} again")
    return HttpResponseRedirect(reverse("submission", args=[sub.pk]))


def _plain(status: int, text: str) -> HttpResponse:
    return HttpResponse(text, status=status, content_type="text/plain; charset=utf-8")


@login_required
def moderation_log(request: HttpRequest, pk: int) -> HttpResponse:
    room = _teacher_class(request, pk)
    events = ModerationEvent.objects.filter(classroom=room).select_related("teacher", "result", "submission")
    return render(request, "course/moderation.html", {"room": room, "events": events[:500]})


View = Callable[..., HttpResponse]
urlpatterns = [
    path("classes/<int:pk>/assignments/<int:apk>/", assignment_page, name="assignment"),
    path("classes/<int:pk>/assignments/<int:apk>/<str:kind>.svg", assignment_chart, name="assignment-chart"),
    path("classes/<int:pk>/students/<int:spk>/dashboard/", student_dashboard, name="dashboard"),
    path("classes/<int:pk>/students/<int:spk>/<str:kind>.svg", student_chart, name="student-chart"),
    path("classes/<int:pk>/moderate/", moderate, name="moderate"),
    path("classes/<int:pk>/moderation/", moderation_log, name="moderation"),
    path("submissions/<int:pk>/", submission_page, name="submission"),
    path("submissions/<int:pk>/reevaluate/", reevaluate, name="reevaluate"),
    path("me/training.svg", my_training_chart, name="my-training-chart"),
]
