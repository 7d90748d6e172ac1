"""How long a crash costs: a course server (default heartbeat and stale times) is SIGKILLed with its worker, queue
processes and sandbox in the middle of an evaluation, then started again; prints the seconds from the kill to the
submission's hand-back (its page says re-queued) and to its last official result.

    python benchmarks/course_recovery.py            # SQLite in a temporary data folder
    DATABASE_URL=postgres://... python benchmarks/course_recovery.py   # a database of its own on that server
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import requests

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from course_procs import CourseServer, setup_class  # noqa: E402
from course_work import OFFICIAL, changed  # noqa: E402

SEEDS = 4


def main() -> None:
    with tempfile.TemporaryDirectory(prefix="robokit-recovery-") as tmp:
        server = CourseServer(Path(tmp) / "data", workers=1)
        token = setup_class(server, ["김민준"])["김민준"]
        official = Path(tmp) / "official.toml"
        official.write_text(OFFICIAL, encoding="utf-8")
        server.manage("create_assignment", "1반", "낙하", "--config", str(official), "--allow", "behaviour.duration",
                      "--seeds", f"0:{SEEDS}")
        server.start()
        try:
            resp = requests.post(f"{server.url}/api/robotics/assignments/낙하/submissions/", timeout=60,
                                 json={"config": changed(OFFICIAL, duration="3.0")},
                                 headers={"Authorization": f"Bearer {token}"})
            resp.raise_for_status()
            stored = "SELECT count(*) FROM course_result"
            server.wait_for("a first trial stored", lambda: server.query(stored)[0][0] >= 1, 300)
            server.kill()
            killed = time.monotonic()
            server.lines.clear()
            server.start()
            started = time.monotonic() - killed
            back = "SELECT count(*) FROM course_submission WHERE requeued > 0"
            server.wait_for("the submission handed back", lambda: server.query(back)[0][0] == 1, 600)
            handed = time.monotonic() - killed
            done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
            server.wait_for("the submission graded", lambda: server.query(done)[0][0] == 1, 600)
            graded = time.monotonic() - killed
        finally:
            server.stop()
        rows = server.query("SELECT count(*), count(DISTINCT seed) FROM course_result")[0]
        note = server.query("SELECT note FROM course_submission")[0][0]
    database = "PostgreSQL" if server.database else "SQLite"
    print(f"{database}: SIGKILL of the whole tree mid-evaluation; restarted after {started:.1f} s; handed back "
          f"{handed:.1f} s after the kill ({note!r}); last official result {graded:.1f} s after it; rows {rows[0]} "
          f"for {rows[1]} seeds of {SEEDS} (load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
