"""Nothing races: a course server that has just started receives 40 concurrent submissions of the unchanged
official sort config (one per student, as a class does at a deadline) and refuses none, and its log keeps every
request's line. Every plugin type is loaded before the server listens, so no request thread ever finds the plugin
tables half-filled or imports anything.

    python -m pytest -q -s -n 0 -m slow tests/test_course_grading_coldstart.py
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import requests
from course_procs import CourseServer, setup_class

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
STUDENTS = 40


def test_a_fresh_server_refuses_none_of_forty_concurrent_valid_submissions(tmp_path: Path) -> None:
    server = CourseServer(tmp_path / "data", workers=0)  # submissions stay queued: this is about taking them
    tokens = setup_class(server, [f"학생{i:02d}" for i in range(STUDENTS)])
    official = ROOT / "configs" / "sort_robot.toml"
    server.manage("create_assignment", "1반", "분류", "--config", str(official), "--seeds", "0:4")
    text = official.read_text(encoding="utf-8")

    def send(token: str) -> tuple[int, str]:
        resp = requests.post(f"{server.url}/api/robotics/assignments/분류/submissions/", json={"config": text},
                             headers={"Authorization": f"Bearer {token}"}, timeout=300)
        return resp.status_code, resp.text[:300]

    server.start()
    try:
        t0 = time.monotonic()
        with ThreadPoolExecutor(STUDENTS) as pool:
            answers = list(pool.map(send, tokens.values()))
        burst = time.monotonic() - t0
    finally:
        server.stop()
    refused = [a for a in answers if a[0] != 201]
    assert not refused, refused
    stored = server.query("SELECT count(*), count(DISTINCT student_id) FROM course_submission WHERE status = 'queued'")
    assert stored == [(STUDENTS, STUDENTS)]
    # and the server's own output survived the burst (threads importing plugins at once, each silencing and
    # restoring the process's stdout and stderr around pybullet's banner, can leave them pointing nowhere)
    assert server.log.count("POST /api/robotics/assignments/분류/submissions/ 201") == STUDENTS, server.log[-2000:]
    print(f"\na freshly started server: {STUDENTS} concurrent submissions answered within {burst:.1f} s, "
          f"{len(refused)} refused")
