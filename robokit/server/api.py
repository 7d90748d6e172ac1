"""The API: ``POST /api/robotics/result/`` (lesson 08's contract, robokit's payload) and a run's artifacts.

Answers are JSON. Errors are ``{"error": "<one line>", "field": "<the field>"}`` with 400 (bad field), 401
(token), 404, 405, 409 (an idempotency key used by someone else, or an artifact name with other content) or 413
(too large).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import uuid
from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.exceptions import RequestDataTooBig, TooManyFilesSent
from django.core.files.uploadedfile import SimpleUploadedFile
from django.db import IntegrityError, transaction
from django.http import HttpRequest, JsonResponse
from django.http.multipartparser import MultiPartParserError
from django.utils import timezone
from django.views.decorators.csrf import csrf_exempt

from robokit.server import tokens
from robokit.server.artifacts import ArtifactError, check_content, kind_for
from robokit.server.models import Artifact, Classroom, Project, Result, Student, Token
from robokit.server.payload import RUN_ID, PayloadError, Posted, check, config_name, default_ranking, parse
from robokit.server.private import private_dir

TEXT_KINDS = ("plot", "trace", "config", "replay")


def error(status: int, field: str, message: str, **headers: str) -> JsonResponse:
    """A JSON error naming the field."""
    text = f"{field}: {message}" if field else message
    response = JsonResponse({"error": text, "field": field or None}, status=status,
                            json_dumps_params={"ensure_ascii": False})
    for key, value in headers.items():
        response[key.replace("_", "-")] = value
    return response


def _token(request: HttpRequest) -> Token | None:
    """The request's token row, None without one. Raises TokenError for a bad, unknown or revoked token."""
    raw = tokens.from_header(request.headers.get("Authorization"))
    return tokens.find(raw) if raw is not None else None


def _unauthorized(message: str) -> JsonResponse:
    """401 naming ``Authorization``; the message itself says what is wrong with the token (or that none came)."""
    response = JsonResponse({"error": message, "field": "Authorization"}, status=401,
                            json_dumps_params={"ensure_ascii": False})
    response["WWW-Authenticate"] = 'Bearer realm="robokit"'
    return response


@csrf_exempt
def post_result(request: HttpRequest) -> JsonResponse:
    """Store one result. 201 with the record; 200 with the first record for a repeated key."""
    if request.method != "POST":
        return error(405, "", "POST a result here (JSON)", Allow="POST")
    if request.content_type != "application/json":
        got = request.content_type or "none"
        return error(415, "Content-Type", f"send the result as 'Content-Type: application/json' (got {got!r})")
    length = _content_length(request)
    if length > settings.MAX_RESULT_BYTES:
        return error(413, "", f"the body is {length} bytes; the limit is {settings.MAX_RESULT_BYTES}")
    try:
        body = request.body
        token = _token(request)
    except RequestDataTooBig:
        return error(413, "", f"the body is over the {settings.MAX_RESULT_BYTES}-byte limit")
    except tokens.TokenError as exc:
        return _unauthorized(str(exc))
    if token is None and not Classroom.objects.filter(allow_unverified=True).exists():
        return _unauthorized(NO_TOKEN.format(where="this server takes results only with a token"))
    try:
        posted = check(parse(body), student_required=False, idempotency_key=request.headers.get("Idempotency-Key"))
        classroom = token.classroom if token is not None else _open_classroom(posted)
        if token is None and posted.student is None:
            raise PayloadError("student", "missing (a post without a token must say who it is from)")
    except PayloadError as exc:
        return error(400, exc.field, exc.message)
    except NoToken as exc:
        return _unauthorized(str(exc))
    if posted.run_id is not None:
        existing = Result.objects.select_related("classroom", "project", "token").filter(run_id=posted.run_id)
        if first := existing.first():
            return _repeat(first, token)
    run_id = posted.run_id or uuid.uuid4().hex
    try:
        with transaction.atomic():
            record = _store(posted, run_id, classroom, token)
    except IntegrityError:  # a concurrent request with the same key won the insert
        first = Result.objects.select_related("classroom", "project", "token").filter(run_id=run_id).first()
        if first is None:
            raise
        return _repeat(first, token)
    return JsonResponse(record.to_dict(), status=201, json_dumps_params={"ensure_ascii": False})


def _content_length(request: HttpRequest) -> int:
    try:
        return max(int(request.META.get("CONTENT_LENGTH") or 0), 0)
    except ValueError:
        return 0


class NoToken(Exception):
    """A post without a token to a class that needs one (-> 401)."""


NO_TOKEN = ("no token sent: {where}; send 'Authorization: Bearer <token>' "
            "(robokit: export ROBOKIT_TOKEN=<the token your teacher gave you>)")


def _open_classroom(posted: Posted) -> Classroom:
    """The class a post without a token goes to (only classes that accept unverified posts).

    Raises:
        NoToken: the class named, or every class, takes results only with a token (-> 401).
        PayloadError: several classes take posts without a token and the post does not say which (-> 400 naming
            ``classroom``).
    """
    open_classes = list(Classroom.objects.filter(allow_unverified=True))
    if posted.classroom is not None:
        for c in open_classes:
            if c.name == posted.classroom:
                return c
        raise NoToken(NO_TOKEN.format(where=f"class {posted.classroom!r} takes results only with a token"))
    if not open_classes:
        raise NoToken(NO_TOKEN.format(where="this server takes results only with a token"))
    if len(open_classes) == 1:
        return open_classes[0]
    named = {s.classroom_id for s in Student.objects.filter(name=posted.student, classroom__in=open_classes)}
    if len(named) == 1:
        return next(c for c in open_classes if c.pk in named)
    raise PayloadError("classroom", "several classes accept results without a token: say which one with "
                       "\"classroom\": \"<class name>\"")


def _owner(token: Token | None) -> tuple[str, int | None] | None:
    if token is None:
        return None
    return (Token.TEACHER, token.teacher_id) if token.kind == Token.TEACHER else (Token.STUDENT, token.student_id)


def _record_owner(record: Result) -> tuple[str, int | None] | None:
    if not record.verified:
        return None
    if record.official:
        return (Token.TEACHER, record.token.teacher_id if record.token is not None else None)
    return (Token.STUDENT, record.student_id)


def _repeat(record: Result, token: Token | None) -> JsonResponse:
    """The answer to a key seen before: the first record (200), unless someone else sent it (409)."""
    if _owner(token) != _record_owner(record):
        return error(409, "run_id", "this run id was already posted by someone else")
    return JsonResponse(record.to_dict(), status=200, json_dumps_params={"ensure_ascii": False})


def _store(posted: Posted, run_id: str, classroom: Classroom, token: Token | None) -> Result:
    data = posted.data
    if isinstance(data.get("config"), str):
        data["config"] = config_name(data["config"])
    project, _ = Project.objects.get_or_create(classroom=classroom, name=posted.project,
                                               defaults={"ranking": default_ranking(posted.figures)})
    if token is not None and token.kind == Token.STUDENT:
        student: Student | None = token.student
        name = token.student.name if token.student is not None else ""
    else:
        name = posted.student or (str(token.teacher) if token is not None else "")
        student = Student.objects.filter(classroom=classroom, name=name).first()
    if token is not None:
        Token.objects.filter(pk=token.pk).update(last_used_at=timezone.now())
    return Result.objects.create(
        run_id=run_id, classroom=classroom, project=project, student=student, student_name=name,
        posted_student=posted.student or "", token=token, verified=token is not None,
        official=token is not None and token.kind == Token.TEACHER,
        outcome=data.get("outcome") or "", reason=(data.get("reason") or "")[:2000],
        behaviour=(data.get("behaviour") or "")[:100], config=(data.get("config") or "")[:300],
        seed=data.get("seed"), sim_time=data.get("sim_time"), wall_time=data.get("wall_time"),
        started_at=(data.get("started_at") or "")[:40], red_sorted=data.get("red_sorted"),
        blue_sorted=data.get("blue_sorted"), failures=data.get("failures"), total_time=data.get("total_time"),
        figures=posted.figures, payload=data,
    )


def max_artifact_request() -> int:
    """The largest artifact upload request: one video, one trace, a config, a replay and eight plots."""
    return (settings.MAX_VIDEO_BYTES + settings.MAX_TRACE_BYTES + settings.MAX_CONFIG_BYTES
            + settings.MAX_REPLAY_BYTES + 8 * settings.MAX_PLOT_BYTES + (64 << 10))


@csrf_exempt
def post_artifacts(request: HttpRequest, run_id: str) -> JsonResponse:
    """Upload a run's files (multipart, any field name): 201 when something new was stored, else 200."""
    if request.method != "POST":
        return error(405, "", "POST files here (multipart/form-data)", Allow="POST")
    if not RUN_ID.match(run_id):
        return error(404, "run_id", "no such run")
    length = _content_length(request)
    if length > max_artifact_request():
        return error(413, "", f"the upload is {length} bytes; the limit is {max_artifact_request()}")
    record = Result.objects.select_related("classroom", "token").filter(run_id=run_id).first()
    if record is None:
        return error(404, "run_id", "no such run: post the result first")
    try:
        token = _token(request)
    except tokens.TokenError as exc:
        return _unauthorized(str(exc))
    if token is None and not _may_upload(record, token):
        return _unauthorized(NO_TOKEN.format(where="only the run's owner or the class's teacher may upload its files"))
    if not _may_upload(record, token):
        return error(403, "Authorization", "this token may not upload files for this run: only the run's owner "
                     "(with their token) or the class's teacher may")
    try:
        files = [f for name in request.FILES for f in request.FILES.getlist(name)]
    except (MultiPartParserError, TooManyFilesSent, RequestDataTooBig) as exc:
        return error(400, "file", f"a multipart/form-data upload was expected ({exc})")
    if not files:
        return error(400, "file", "no file in the upload (send multipart/form-data with one or more files)")
    stored_names = set(record.artifacts.values_list("name", flat=True))
    names = stored_names | {os.path.basename(f.name or "") for f in files}
    if len(names) > settings.MAX_ARTIFACTS_PER_RUN:  # files already stored count; sending one again does not
        return error(400, "file", f"a run keeps at most {settings.MAX_ARTIFACTS_PER_RUN} files "
                     f"({len(stored_names)} stored, {len(names) - len(stored_names)} new in this upload)")
    checked = []
    for upload in files:
        try:
            checked.append(_check_upload(upload))
        except ArtifactError as exc:
            status = 413 if "limit" in str(exc) else 400
            return error(status, "file", str(exc))
    stored, created = [], False
    for upload, kind, digest in checked:
        artifact, new = _store_artifact(record, upload, kind, digest)
        if artifact is None:
            return error(409, "file", f"{upload.name!r} was already uploaded for this run with other content")
        stored.append(artifact.to_dict())
        created = created or new
    return JsonResponse({"run_id": run_id, "artifacts": stored}, status=201 if created else 200)


def _may_upload(record: Result, token: Token | None) -> bool:
    if token is None:
        return not record.verified and record.classroom.allow_unverified
    if token.classroom_id != record.classroom_id:
        return False
    if token.kind == Token.TEACHER:
        return True
    return record.verified and not record.official and token.student_id == record.student_id


def _check_upload(upload: Any) -> tuple[Any, Any, str]:
    name = os.path.basename(upload.name or "")
    upload.name = name
    kind = kind_for(name)
    limit = getattr(settings, kind.limit_setting)
    if upload.size > limit:
        raise ArtifactError(f"{name!r} is {upload.size} bytes; the limit for a {kind.kind} is {limit}")
    upload.seek(0)
    head = upload.read(64)
    upload.seek(0)
    whole = upload.read() if kind.kind in TEXT_KINDS and not name.endswith(".png") else None
    replacement = check_content(name, kind, head, whole)
    if replacement is not None:  # an SVG: what is stored (and hashed) is the rebuilt file, never the upload
        upload = SimpleUploadedFile(name, replacement, content_type=kind.content_type)
    digest = hashlib.sha256()
    upload.seek(0)
    for chunk in upload.chunks():
        digest.update(chunk)
    return upload, kind, digest.hexdigest()


def _store_artifact(record: Result, upload: Any, kind: Any, digest: str) -> tuple[Artifact | None, bool]:
    """Store one file (row and file together); an existing name with the same content is returned as is."""
    rel = f"artifacts/{record.run_id}/{upload.name}"
    try:
        with transaction.atomic():
            artifact = Artifact.objects.create(result=record, name=upload.name, kind=kind.kind,
                                               content_type=kind.content_type, size=upload.size, sha256=digest,
                                               path=rel)
            _write_file(Path(settings.MEDIA_ROOT) / rel, upload)
    except IntegrityError:
        existing = Artifact.objects.get(result=record, name=upload.name)
        return (existing if existing.sha256 == digest else None), False
    return artifact, True


def _write_file(dest: Path, upload: Any) -> None:
    """Write through a temporary file and rename, so a reader never sees half a file. Folders are made 0700 and
    the file is 0600 (``mkstemp``'s mode, kept by the rename)."""
    private_dir(dest.parent)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.name}.", dir=dest.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            upload.seek(0)
            for chunk in upload.chunks():
                fh.write(chunk)
        os.replace(tmp, dest)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
