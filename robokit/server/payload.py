"""Checking a posted result: lesson 08's six fields, or robokit's full RunResult payload.

Lesson 08 sends ``{"student", "project", "red_sorted", "blue_sorted", "failures", "total_time"}``; robokit's
``http`` reporter sends the RunResult (``schema``, ``run_id``, ``outcome``, ``result`` ...) with the same six
fields at top level. Every error names the field it is about.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any

MAX_NAME = 100
RUN_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._:-]{0,63}$")
OUTCOMES = ("succeeded", "failed", "aborted", "error", "interrupted")
COURSE_INTS = ("red_sorted", "blue_sorted", "failures")
MAX_COUNT = 2**31 - 1
INT_MIN, INT_MAX = -(2**63), 2**63 - 1
MAX_DEPTH = 32


class PayloadError(Exception):
    """A field is missing or has the wrong type; ``field`` names it (``""`` for the body as a whole)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}" if field else message)
        self.field = field
        self.message = message


@dataclass
class Posted:
    """The checked content of one post."""

    data: dict[str, Any]
    student: str | None
    project: str
    run_id: str | None
    classroom: str | None
    figures: dict[str, float | int] = field(default_factory=dict)


def _kind(value: Any) -> str:
    return {dict: "an object", list: "a list", str: "a string", bool: "true/false", type(None): "null"}.get(
        type(value), "a number" if isinstance(value, (int, float)) else type(value).__name__)


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def parse(body: bytes) -> dict[str, Any]:
    """The body as a JSON object whose every value Python and the database can hold.

    Numbers are judged before Python converts them: an integer with more digits than a 64-bit one has, a number
    that overflows to infinity (``1e400``), ``NaN`` and ``Infinity`` are refused naming where they are (so Python's
    own limit on converting long digit strings is never reached); so are strings that are not valid Unicode,
    NUL characters and nesting deeper than :data:`MAX_DEPTH`.

    Raises:
        PayloadError: not UTF-8, not JSON, not an object, or a value as above (``field`` is its path, e.g.
            ``result.score`` or ``result.objects[2].x``).
    """
    try:
        data = json.loads(body.decode("utf-8"), parse_int=_int, parse_float=_float, parse_constant=_constant)
    except UnicodeDecodeError:
        raise PayloadError("", "the body is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise PayloadError("", f"malformed JSON: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except RecursionError:
        raise PayloadError("", "malformed JSON: nested too deeply") from None
    if not isinstance(data, dict):
        raise PayloadError("", f"expected a JSON object, got {_kind(data)}")
    _check_values(data, "", 0)
    return data


@dataclass(frozen=True)
class _Refused:
    """A JSON number Python or the database cannot hold, kept in place until its path is known."""

    message: str


def _int(text: str) -> int | _Refused:
    digits = text.lstrip("-")
    if len(digits) > 19 or not INT_MIN <= int(text) <= INT_MAX:
        shown = text if len(text) <= 24 else f"{text[:12]}... ({len(digits)} digits)"
        return _Refused(f"{shown} does not fit in a 64-bit whole number")
    return int(text)


def _float(text: str) -> float | _Refused:
    value = float(text)
    if not math.isfinite(value):
        shown = text if len(text) <= 24 else f"{text[:12]}..."
        return _Refused(f"{shown} is too large for a number")
    return value


def _constant(name: str) -> _Refused:
    return _Refused(f"{name} is not a JSON number (send null)")


def _check_values(value: Any, path: str, depth: int) -> None:
    """Refuse what :func:`parse` promises to refuse, naming the path of the first such value."""
    if depth > MAX_DEPTH:
        raise PayloadError(path, f"nested more than {MAX_DEPTH} levels deep")
    if isinstance(value, _Refused):
        raise PayloadError(path, value.message)
    if isinstance(value, str):
        _check_text(value, path)
    elif isinstance(value, dict):
        for key, item in value.items():
            _check_text(key, path or "(a key)")
            _check_values(item, _join(path, key), depth + 1)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_values(item, f"{path}[{i}]", depth + 1)


_PLAIN_KEY = re.compile(r"^[A-Za-z0-9_-]{1,40}$")


def _join(path: str, key: str) -> str:
    """``result.score``; a key that is not a plain name is quoted (``result["a b"]``), so a path is one line."""
    if _PLAIN_KEY.match(key):
        return f"{path}.{key}" if path else key
    quoted = json.dumps(key[:40])
    return f"{path}[{quoted}]"


def _check_text(text: str, path: str) -> None:
    if "\x00" in text:
        raise PayloadError(path, "contains a NUL character")
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise PayloadError(path, "not valid Unicode text (a lone surrogate escape)") from None


def _name(data: dict[str, Any], key: str, required: bool) -> str | None:
    value = data.get(key)
    if value is None:
        if required:
            raise PayloadError(key, "missing")
        return None
    if not isinstance(value, str):
        raise PayloadError(key, f"expected a string, got {_kind(value)}")
    value = " ".join(value.split())
    if not value:
        raise PayloadError(key, "empty")
    if len(value) > MAX_NAME:
        raise PayloadError(key, f"longer than {MAX_NAME} characters")
    return value


def _check_types(data: dict[str, Any]) -> None:
    for key in COURSE_INTS:
        if key in data and data[key] is not None:
            v = data[key]
            if not isinstance(v, int) or isinstance(v, bool):
                raise PayloadError(key, f"expected a whole number, got {_kind(v)}")
            if not 0 <= v <= MAX_COUNT:
                raise PayloadError(key, f"expected a number from 0 to {MAX_COUNT}, got {v}")
    for key in ("total_time", "sim_time", "wall_time"):
        v = data.get(key)
        if v is not None and (not is_number(v) or v < 0):
            raise PayloadError(key, f"expected a number >= 0 (seconds), got {_kind(v) if not is_number(v) else v}")
    strings = ("schema", "outcome", "reason", "config", "behaviour", "started_at", "robokit_version")
    for key in strings:
        if key in data and data[key] is not None and not isinstance(data[key], str):
            raise PayloadError(key, f"expected a string, got {_kind(data[key])}")
    if data.get("outcome") is not None and data["outcome"] not in OUTCOMES:
        raise PayloadError("outcome", f"expected one of {', '.join(OUTCOMES)}, got {data['outcome']!r}")
    for key in ("seed", "ticks"):
        v = data.get(key)
        if v is not None and (not isinstance(v, int) or isinstance(v, bool)):
            raise PayloadError(key, f"expected a whole number, got {_kind(v)}")
        if v is not None and not -(2**63) <= v < 2**63:
            raise PayloadError(key, "out of range (a 64-bit whole number was expected)")
    if "result" in data and data["result"] is not None and not isinstance(data["result"], dict):
        raise PayloadError("result", f"expected an object, got {_kind(data['result'])}")
    if "interrupted" in data and not isinstance(data["interrupted"], bool):
        raise PayloadError("interrupted", f"expected true/false, got {_kind(data['interrupted'])}")


def check(data: dict[str, Any], *, student_required: bool, idempotency_key: str | None) -> Posted:
    """Check a parsed body.

    Args:
        data: The JSON object posted.
        student_required: A post without a token must say who it is from.
        idempotency_key: The ``Idempotency-Key`` header, if any; it must agree with ``run_id`` when both are sent.

    Raises:
        PayloadError: naming the first field that is wrong.
    """
    student = _name(data, "student", student_required)
    project = _name(data, "project", True)
    assert project is not None
    classroom = _name(data, "classroom", False)
    _check_types(data)
    run_id = data.get("run_id")
    if run_id is not None and (not isinstance(run_id, str) or not RUN_ID.match(run_id)):
        raise PayloadError("run_id", "expected 1-64 letters, digits, '.', '_', ':' or '-'")
    if idempotency_key is not None:
        if not RUN_ID.match(idempotency_key):
            raise PayloadError("Idempotency-Key", "expected 1-64 letters, digits, '.', '_', ':' or '-'")
        if run_id is not None and run_id != idempotency_key:
            raise PayloadError("Idempotency-Key", "differs from the payload's run_id")
        run_id = idempotency_key
    return Posted(data, student, project, run_id, classroom, figures(data))


def figures(data: dict[str, Any]) -> dict[str, float | int]:
    """The run's numbers: the course fields, the behaviour's numeric results, and ``sorted_total`` (the sum of
    every ``*_sorted`` count) when there are any."""
    out: dict[str, float | int] = {}
    result = data["result"] if isinstance(data.get("result"), dict) else {}
    for source in (result, data):
        for key, value in source.items():
            if is_number(value) and key not in ("seed", "ticks", "wall_time", "sim_time"):
                out[str(key)[:50]] = value
    sorted_counts = [v for k, v in out.items() if k.endswith("_sorted")]
    if sorted_counts:
        out["sorted_total"] = sum(sorted_counts)
    if is_number(data.get("sim_time")) and "total_time" not in out:
        out["sim_time"] = data["sim_time"]
    return dict(list(out.items())[:40])


def config_name(path: str) -> str:
    """What the server keeps of a run's config path: its file name (``sort_robot.toml``), whether the student
    sent ``configs/sort_robot.toml``, ``/home/kim/robots/sort_robot.toml`` or ``C:\\Users\\kim\\sort.toml``, so
    a student's local folders (often named after them) are never stored or shown."""
    return re.split(r"[/\\]", path.strip().rstrip("/\\"))[-1]


def default_ranking(figs: dict[str, Any]) -> str:
    """A project's ranking when its first result arrives (the teacher can change it in the admin)."""
    if "sorted_total" in figs:
        keys = ["-sorted_total", "failures", "total_time"]
    elif "collected" in figs or "objects_collected" in figs:
        keys = ["-collected" if "collected" in figs else "-objects_collected", "collisions", "total_time"]
    else:
        keys = ["total_time" if "total_time" in figs else "sim_time"]
    return ",".join(k for k in keys if k.lstrip("-") in figs) or ",".join(keys)
