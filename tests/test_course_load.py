"""A class of 40 submitting at once before a deadline (40 submissions x 20 official seeds), evaluated by one queue
worker and by two: no submission lost or evaluated twice; prints the time from the burst to the last official result.

    python -m pytest -q -s -p no:randomly -m slow tests/test_course_load.py
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import requests
from course_procs import CourseServer, setup_class
from course_work import OFFICIAL, changed

pytestmark = pytest.mark.slow
STUDENTS, SEEDS = 40, 20


@pytest.mark.parametrize("workers", [1, 2])
def test_forty_students_twenty_seeds(tmp_path: Path, workers: int) -> None:
    server = CourseServer(tmp_path / "data", workers=workers)
    tokens = setup_class(server, [f"학생{i:02d}" for i in range(STUDENTS)])
    assert len(tokens) == STUDENTS
    official = tmp_path / "official.toml"
    official.write_text(OFFICIAL, encoding="utf-8")
    server.manage("create_assignment", "1반", "낙하", "--config", str(official), "--allow", "behaviour.duration",
                  "--seeds", f"0:{SEEDS}")
    server.start()

    def send(token: str) -> int:
        resp = requests.post(f"{server.url}/api/robotics/assignments/낙하/submissions/", timeout=300,
                             json={"config": changed(OFFICIAL, duration="0.4")},
                             headers={"Authorization": f"Bearer {token}"})
        return resp.status_code

    try:
        t0 = time.monotonic()
        with ThreadPoolExecutor(STUDENTS) as pool:
            codes = list(pool.map(send, tokens.values()))
        burst = time.monotonic() - t0
        assert codes == [201] * STUDENTS
        done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
        server.wait_for("every submission evaluated", lambda: server.query(done)[0][0] == STUDENTS, 3600)
        total = time.monotonic() - t0
    finally:
        server.stop()
    per = server.query("SELECT submission_id, count(*), count(DISTINCT seed) FROM course_result "
                       "WHERE submission_id IS NOT NULL GROUP BY submission_id")
    assert len(per) == STUDENTS and all(n == SEEDS and d == SEEDS for _, n, d in per)
    attempts = server.query("SELECT attempts, count(*) FROM course_submission GROUP BY attempts")
    assert attempts == [(1, STUDENTS)]  # each evaluated by one worker, once
    wall = server.query("SELECT sum(wall_time) FROM course_result")[0][0]
    database = "PostgreSQL" if server.database else "SQLite"
    print(f"\n{STUDENTS} submissions x {SEEDS} seeds, {workers} worker(s), {database}: burst of posts {burst:.1f} s, "
          f"last official result {total:.1f} s after the first post; trials' own wall time {wall:.0f} s in all "
          f"(load {os.getloadavg()[0]:.1f})")
