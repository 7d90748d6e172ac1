"""The server SIGKILLed (with its queue workers and sandboxes) in the middle of evaluations, then restarted:
the submission that was being evaluated goes back to the queue once its heartbeat is stale (its page says so), the
killed evaluation's scratch folder is removed, and every submission is evaluated exactly once - each official trial
stored once, none lost, none that had finished run again."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
import requests
from course_procs import CourseServer, setup_class
from course_work import OFFICIAL, changed

pytestmark = pytest.mark.slow
SEEDS = 4


def test_sigkill_mid_evaluation_then_restart_evaluates_every_submission_exactly_once(tmp_path: Path) -> None:
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = {"ROBOKIT_QUEUE_HEARTBEAT": "1", "ROBOKIT_QUEUE_STALE": "8", "TMPDIR": str(scratch)}
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
        killed = time.monotonic()
        before = {(s, seed): (pk, at) for s, seed, pk, at in server.query(trials)}
        states = dict(server.query("SELECT id, status FROM course_submission"))
        assert 1 <= len(before) < 3 * SEEDS and "running" in states.values(), (before, states)
        left = [p.name for p in scratch.iterdir() if p.name.startswith("robokit-eval-")]
        assert left, "the killed evaluation left its scratch folder"

        server.lines.clear()
        server.start()
        assert not any((scratch / name).exists() for name in left)  # removed before the worker took work
        requeued = "SELECT count(*) FROM course_submission WHERE requeued > 0 OR status = 'done'"
        server.wait_for("the killed evaluation handed back", lambda: server.query(requeued)[0][0] == 3, 120)
        noticed = time.monotonic() - killed
        done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
        server.wait_for("every submission evaluated", lambda: server.query(done)[0][0] == 3, 300)
        print(f"\nhanded back {noticed:.1f} s after the SIGKILL (stale after 8 s); all done "
              f"{time.monotonic() - killed:.1f} s after it")
    finally:
        server.stop()
    after = server.query(trials)
    per_submission = {s: sorted(seed for s2, seed, _, _ in after if s2 == s) for s in states}
    assert per_submission == {s: list(range(SEEDS)) for s in states}  # each seed once: none lost, none doubled
    assert len(after) == 3 * SEEDS
    kept = {(s, seed): (pk, at) for s, seed, pk, at in after}
    assert all(kept[key] == value for key, value in before.items())  # a finished trial was never run again
    rows = server.query("SELECT id, status, trials, succeeded, success_rate, attempts, requeued, note "
                        "FROM course_submission")
    assert all(r[1:5] == ("done", SEEDS, SEEDS, 1.0) for r in rows), rows
    running = [r for r in rows if states[r[0]] == "running"]
    assert len(running) == 1 and running[0][5:7] == (2, 1), rows  # resumed once, by a second attempt
    assert re.fullmatch(r"re-queued at \d\d:\d\d UTC: the worker evaluating it stopped", running[0][7]), running
    assert all(r[6] == 0 and r[7] == "" for r in rows if r not in running)
    assert len(re.findall(r"Processed .*evaluate submission", server.log)) >= 1
