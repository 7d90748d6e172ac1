"""The course API: a student submits a config for an assignment, and posts a training log.

``POST /api/robotics/assignments/<name>/submissions/`` ``{"config": "<TOML text>"}`` with the student's token:
201 with the submission (queued for official evaluation); 400 naming the key a config may not change, a file it
may not name, or that robokit's validation refuses; 403 before the assignment opens or after it is due when late
work is refused; 413 a config over ``MAX_CONFIG_BYTES``; 429 over the assignment's per-student limits
(:mod:`robokit.server.fair_queue`), saying when to submit again. An ``Idempotency-Key`` is unique per student (a
database constraint): a post with a stored key answers 200 with that submission (409 with another config). With
``"plugin_files": {"path.py": "source", ...}`` (the assignment must allow it, else 403): the student's own plugin
package, checked by :mod:`robokit.server.plugin_upload` and imported only in a sandbox process: the config is
loaded with it there before the submission is accepted (400 naming the key, as for any config), and the trials run
with it there.

``POST /api/robotics/training/`` ``{"name": "...", "run_id": "...", "log": "<JSON lines>"}`` with the token: a
training run (one object per line with ``steps`` and any of ``episodes``, ``return``, ``success_rate``; or
``python -m robokit.gym.train``'s ``progress.jsonl`` as it is: ``env_steps``, ``return_mean``, its ``summary`` line
skipped), plotted on the student's page. 201, or 200 for a ``run_id`` already stored.
"""

from __future__ import annotations

import json
import math
import uuid
from typing import Any

from django.conf import settings
from django.core.exceptions import RequestDataTooBig
from django.db import IntegrityError, transaction
from django.http import HttpRequest, JsonResponse
from django.utils import timezone
from django.views.decorators.csrf import csrf_exempt

from robokit.server import tokens
from robokit.server.api import NO_TOKEN, _token, _unauthorized, error
from robokit.server.assignments import Assignment, Submission, TrainingRun
from robokit.server.evaluation import create_submission, official_overrides
from robokit.server.fair_queue import LimitReached, admit
from robokit.server.models import Token
from robokit.server.payload import RUN_ID, PayloadError, parse
from robokit.server.plugin_upload import MAX_BYTES as MAX_PLUGIN_BYTES
from robokit.server.plugin_upload import check_plugin_config, check_plugin_files
from robokit.server.submitted import SubmissionError, scrub

MAX_TRAINING_POINTS = 20_000


def _student_token(request: HttpRequest) -> Token | JsonResponse:
    """The request's student token, or the answer refusing it."""
    if request.method != "POST":
        return error(405, "", "POST JSON here", Allow="POST")
    if request.content_type != "application/json":
        return error(415, "Content-Type", f"send JSON with 'Content-Type: application/json' "
                     f"(got {request.content_type or 'none'!r})")
    try:
        token = _token(request)
    except tokens.TokenError as exc:
        return _unauthorized(str(exc))
    if token is None:
        return _unauthorized(NO_TOKEN.format(where="submissions and training logs need a student's token"))
    if token.kind != Token.STUDENT or token.student is None:
        return error(403, "Authorization", "only a student's token may submit (this is a teacher's token)")
    return token


def _body(request: HttpRequest, limit: int) -> dict[str, Any]:
    """The JSON object posted, at most ``limit`` bytes (and at most Django's request limit, the results' one)."""
    try:
        body = request.body
    except RequestDataTooBig:
        raise PayloadError("", f"the body is over the {settings.MAX_RESULT_BYTES}-byte limit") from None
    if len(body) > limit:
        raise PayloadError("", f"the body is {len(body)} bytes; the limit is {limit}")
    return parse(body)


@csrf_exempt
def submit(request: HttpRequest, name: str) -> JsonResponse:
    """A student's config for an assignment of their class."""
    token = _student_token(request)
    if isinstance(token, JsonResponse):
        return token
    assignment = Assignment.objects.select_related("classroom", "project").filter(
        classroom=token.classroom, name=name).first()
    if assignment is None:
        known = ", ".join(repr(a.name) for a in token.classroom.assignments.all()[:20]) or "none yet"
        return error(404, "assignment", f"no assignment {name!r} in class {token.classroom.name!r} "
                     f"(assignments: {known})")
    try:
        key = idempotency_key(request)
        body = _body(request, settings.MAX_CONFIG_BYTES + MAX_PLUGIN_BYTES + 8192)
        text = body.get("config")
        if not isinstance(text, str) or not text.strip():
            raise PayloadError("config", "expected the config file's text (a string)")
        size = len(text.encode("utf-8"))
        if size > settings.MAX_CONFIG_BYTES:
            raise PayloadError("config", f"the config is {size} bytes; the limit is {settings.MAX_CONFIG_BYTES}")
    except PayloadError as exc:
        return error(413 if "limit" in exc.message else 400, exc.field, exc.message)
    repeat = _repeated(key, token, assignment, text)  # a resend is the submission it made, also after the due time
    if repeat is not None:
        return repeat
    plugin_files = body.get("plugin_files")
    if plugin_files and not assignment.allow_plugins:
        return error(403, "plugin", f"{assignment.name!r} does not accept plugin packages: submit the config alone "
                     "(your teacher decides whether an assignment takes students' own plugins)")
    now = timezone.now()
    if assignment.opens_at is not None and now < assignment.opens_at:
        return error(403, "opens_at", f"{assignment.name!r} opens at {assignment.opens_at.isoformat()}")
    late = assignment.due_at is not None and now > assignment.due_at
    if late and assignment.late_policy == Assignment.REFUSE:
        return error(403, "due_at", f"{assignment.name!r} was due at {assignment.due_at.isoformat()}; "
                     f"late submissions are refused")
    try:
        modules = check_plugin_files(plugin_files) if plugin_files else []
        assignment.check_config(text, validate=not modules)
        with transaction.atomic():  # before the sandbox's check; counted again when stored
            admit(assignment, token.student_id)
        if modules and isinstance(plugin_files, dict):  # its types: checked in a sandbox process, not here
            check_plugin_config(text, plugin_files, modules, official_overrides(assignment.trial_seconds))
    except SubmissionError as exc:
        return error(400, exc.field, scrub(exc.message))
    except LimitReached as exc:
        return _repeated(key, token, assignment, text) or _over(exc)

    Token.objects.filter(pk=token.pk).update(last_used_at=now)
    try:
        sub = create_submission(admit=lambda: admit(assignment, token.student_id),
                                assignment=assignment, student=token.student, config_text=text, late=late,
                                plugin_files=plugin_files or {}, plugin_modules=modules, idempotency_key=key)
    except LimitReached as exc:  # e.g. the same post, stored a moment ago by a request racing this one
        return _repeated(key, token, assignment, text) or _over(exc)
    except IntegrityError:  # the unique (student, key) constraint: this key is stored already
        answer = _repeated(key, token, assignment, text)
        if answer is None:
            raise
        return answer
    return JsonResponse(sub.to_dict(), status=201, json_dumps_params={"ensure_ascii": False})


def _over(exc: LimitReached) -> JsonResponse:
    return error(429, exc.field, exc.message, **{"Retry-After": str(exc.retry_after)})


def idempotency_key(request: HttpRequest) -> str | None:
    """The ``Idempotency-Key`` header (None without one).

    Raises:
        PayloadError: a key that is not 1-64 letters, digits, '.', '_', ':' or '-'.
    """
    key = request.headers.get("Idempotency-Key")
    if key is None:
        return None
    if not RUN_ID.match(key):
        raise PayloadError("Idempotency-Key", "expected 1-64 letters, digits, '.', '_', ':' or '-'")
    return key


def _repeated(key: str | None, token: Token, assignment: Assignment, text: str) -> JsonResponse | None:
    """The answer to a post whose ``Idempotency-Key`` is stored already: that submission (200), or 409 when the
    key came with another assignment or config; None when the key is not stored (or there is none)."""
    sub = Submission.objects.select_related("assignment", "student").filter(
        student=token.student, idempotency_key=key).first() if key is not None else None
    if sub is None:
        return None
    if sub.assignment_id != assignment.pk or sub.config_text != text:
        return error(409, "Idempotency-Key", f"this key was already used for submission {sub.pk} with another "
                     "assignment or config: send a new key for a new submission")
    return JsonResponse(sub.to_dict(), status=200, json_dumps_params={"ensure_ascii": False})


@csrf_exempt
def post_training(request: HttpRequest) -> JsonResponse:
    """A training log (JSON lines) of the token's student."""
    token = _student_token(request)
    if isinstance(token, JsonResponse):
        return token
    try:
        data = _body(request, settings.MAX_RESULT_BYTES)
        run_id = data.get("run_id") or uuid.uuid4().hex
        if not isinstance(run_id, str) or not RUN_ID.match(run_id):
            raise PayloadError("run_id", "expected 1-64 letters, digits, '.', '_', ':' or '-'")
        name = data.get("name") or ""
        if not isinstance(name, str) or len(name) > 100:
            raise PayloadError("name", "expected a string of at most 100 characters")
        points = training_points(data.get("log"))
    except PayloadError as exc:
        return error(413 if "limit" in exc.message else 400, exc.field, exc.message)
    try:
        with transaction.atomic():
            run = TrainingRun.objects.create(run_id=run_id, student=token.student, name=name, points=points)
        status = 201
    except IntegrityError:
        run = TrainingRun.objects.get(run_id=run_id)
        if run.student_id != token.student_id:
            return error(409, "run_id", "this run id was already posted by someone else")
        status = 200
    return JsonResponse({"run_id": run.run_id, "name": run.name, "points": len(run.points),
                         "student": token.student.name}, status=status, json_dumps_params={"ensure_ascii": False})


def training_points(log: Any) -> list[dict[str, float]]:
    """The points of a JSON-lines training log; each line an object with whole ``steps`` and optional numbers.

    Raises:
        PayloadError: naming the line and key (``log[3].steps``).
    """
    if not isinstance(log, str) or not log.strip():
        raise PayloadError("log", "expected the training log's text (JSON lines)")
    points = []
    for i, line in enumerate(log.splitlines(), 1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except ValueError:
            raise PayloadError(f"log[{i}]", "not a JSON object") from None
        if not isinstance(rec, dict):
            raise PayloadError(f"log[{i}]", "not a JSON object")
        if "summary" in rec and "steps" not in rec and "env_steps" not in rec:
            continue  # python -m robokit.gym.train's last line: the evaluation, not a point of the curve
        steps = rec.get("steps", rec.get("env_steps"))
        if not isinstance(steps, int) or isinstance(steps, bool) or steps < 0:
            raise PayloadError(f"log[{i}].steps", "expected a whole number >= 0")
        point: dict[str, float] = {"steps": steps}
        for key, alias in (("episodes", "episodes"), ("return", "return_mean"), ("success_rate", "success_rate")):
            value = rec.get(key, rec.get(alias))
            if value is None:
                continue
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
                raise PayloadError(f"log[{i}].{key}", "expected a finite number")
            if key == "success_rate" and not 0 <= value <= 1:
                raise PayloadError(f"log[{i}].{key}", "expected a number from 0 to 1")
            point[key] = value
        points.append(point)
        if len(points) > MAX_TRAINING_POINTS:
            raise PayloadError("log", f"more than {MAX_TRAINING_POINTS} lines")
    if not points:
        raise PayloadError("log", "no lines")
    return points


def submission_status(request: HttpRequest, pk: int) -> JsonResponse:
    """``GET /api/robotics/submissions/<id>/``: a submission's state, for its student (token) or a teacher."""
    sub = Submission.objects.select_related("assignment__classroom", "student").filter(pk=pk).first()
    try:
        token = _token(request)
    except tokens.TokenError as exc:
        return _unauthorized(str(exc))
    allowed = (token is not None and sub is not None
               and (token.student_id == sub.student_id or (token.kind == Token.TEACHER
                                                            and token.classroom_id == sub.assignment.classroom_id)))
    if not allowed or sub is None:
        return error(404, "submission", "no such submission for this token")
    return JsonResponse(submission_detail(sub), json_dumps_params={"ensure_ascii": False})


def submission_detail(sub: Submission) -> dict[str, Any]:
    """A submission as its student sees it: its state, and each official trial's seed, outcome and reason (the
    server's paths taken out), seed by seed."""
    trials = [{"seed": r.seed, "outcome": r.outcome, "reason": scrub(r.reason), "sim_time": r.sim_time,
               "figures": r.figures, "run_id": r.run_id}
              for r in sub.results.filter(official=True).order_by("seed")]
    return {**sub.to_dict(), "error": scrub(sub.error) or None, "succeeded": sub.succeeded, "requeued": sub.requeued,
            "trials": trials, "finished_at": sub.finished_at.isoformat() if sub.finished_at else None}
