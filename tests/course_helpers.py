"""Helpers of the course server tests: payloads, posting, small files (fixtures are in course_fixtures.py)."""

from __future__ import annotations

import json
import struct
import zlib
from dataclasses import dataclass
from typing import Any

LESSON_08 = {"student": "홍길동", "project": "물체 분류", "red_sorted": 2, "blue_sorted": 2, "failures": 0,
             "total_time": 42.5}
"""Exactly what lesson 08's code posts."""

PASSWORD = "correct-horse-battery"


@dataclass
class Course:
    teacher: Any
    room: Any
    kim: Any
    lee: Any
    kim_token: str
    lee_token: str
    teacher_token: str


def post(client: Any, data: Any, token: str | None = None, key: str | None = None, raw: bytes | None = None) -> Any:
    """POST a result through Django's test client (real views, real database)."""
    headers = {}
    if token is not None:
        headers["HTTP_AUTHORIZATION"] = f"Bearer {token}"
    if key is not None:
        headers["HTTP_IDEMPOTENCY_KEY"] = key
    body = raw if raw is not None else json.dumps(data, ensure_ascii=False).encode("utf-8")
    return client.post("/api/robotics/result/", data=body, content_type="application/json", **headers)


def robokit_payload(i: int = 0, student: str = "kim", project: str = "A", **result: Any) -> dict[str, Any]:
    """A full robokit payload (RunResult + course fields) with a deterministic run id."""
    from robokit.core.result import RunResult
    from robokit.report.reporting import build_payload

    result = result or {"red_sorted": 2, "blue_sorted": 2, "failures": i % 2, "total_time": 8.0 + i,
                        "objects": [{"colour": "red", "detected_position": [0.4, 0.1, 0.025], "outcome": "sorted"}]}
    r = RunResult(run_id=f"00000000-0000-4000-8000-{i:012d}", robokit_version="0.1.0",
                  config="configs/sort_robot.toml", behaviour="sort", seed=i, outcome="succeeded", reason="sorted",
                  ticks=1900, sim_time=8.0 + i, wall_time=1.2, started_at="2026-11-23T10:00:00+00:00", result=result)
    return build_payload(r, student=student, project=project)


def tiny_png(width: int = 4, height: int = 3) -> bytes:
    """A valid RGB PNG (zlib + CRCs by hand)."""
    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    rows = b"".join(b"\x00" + bytes([200, 40, 40]) * width for _ in range(height))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def mp4_head() -> bytes:
    """The start of an MP4 file: an ``ftyp`` box (enough for the type check)."""
    return struct.pack(">I", 24) + b"ftypisom" + struct.pack(">I", 512) + b"isomiso2" + b"\x00" * 64
