"""The server SIGKILLed (with its queue workers and sandboxes) in the middle of evaluations, then restarted:
every submission is evaluated exactly once - each official trial stored once, none lost, none that had
finished run again."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import requests
from course_procs import CourseServer, setup_class
from course_work import OFFICIAL, changed

pytestmark = pytest.mark.slow
SEEDS = 4


def test_sigkill_mid_evaluation_then_restart_evaluates_every_submission_exactly_once(tmp_path: Path) -> None:
    env = {"ROBOKIT_QUEUE_TIMEOUT": "60", "ROBOKIT_QUEUE_RETRY": "65"}  # a taken task comes back after 65 s
    server = CourseServer(tmp_path / "data", workers=1, env=env)
    tokens = setup_class(server, ["김민준", "이서연", "박지호"])
    official = tmp_path / "official.toml"
    official.write_text(OFFICIAL, encoding="utf-8")
    server.manage("create_assignment", "1반", "낙하", "--config", str(official), "--allow", "behaviour.duration",
                  "--seeds", f"0:{SEEDS}", "--trial-seconds", "7")  # 4 x 7 s + 30 s fits the queue's 60 s
    server.start()
    try:
        for name, token in tokens.items():
            resp = requests.post(f"{server.url}/api/robotics/assignments/낙하/submissions/", timeout=60,
                                 json={"config": changed(OFFICIAL, duration="1.5")},
                                 headers={"Authorization": f"Bearer {token}"})
            assert resp.status_code == 201, (name, resp.text)
        trials = "SELECT submission_id, seed, id, received_at FROM course_result WHERE submission_id IS NOT NULL"
        server.wait_for("a first trial stored", lambda: len(server.query(trials)) >= 1, 180)
        server.kill()
        before = {(s, seed): (pk, at) for s, seed, pk, at in server.query(trials)}
        states = dict(server.query("SELECT id, status FROM course_submission"))
        assert 1 <= len(before) < 3 * SEEDS and "running" in states.values(), (before, states)

        server.lines.clear()
        server.start()
        done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
        server.wait_for("every submission evaluated", lambda: server.query(done)[0][0] == 3, 300)
    finally:
        server.stop()
    after = server.query(trials)
    per_submission = {s: sorted(seed for s2, seed, _, _ in after if s2 == s) for s in states}
    assert per_submission == {s: list(range(SEEDS)) for s in states}  # each seed once: none lost, none doubled
    assert len(after) == 3 * SEEDS
    kept = {(s, seed): (pk, at) for s, seed, pk, at in after}
    assert all(kept[key] == value for key, value in before.items())  # a finished trial was never run again
    rows = server.query("SELECT status, trials, succeeded, success_rate, attempts FROM course_submission")
    assert all(r[:4] == ("done", SEEDS, SEEDS, 1.0) for r in rows), rows
    assert sorted(r[4] for r in rows).count(2) >= 1  # the interrupted one was resumed by a second attempt
    assert len(re.findall(r"Processed .*evaluate submission", server.log)) >= 1
