"""``robokit serve`` and its worker stop on SIGTERM and SIGINT at any moment - starting, starting its worker, idle,
in the middle of an evaluation - and leave no process behind; what was being evaluated goes back to the queue
(no trial graded by the stop) and is evaluated once when the server runs again. A server killed on its own takes
its worker with it.

    python -m pytest -q -s -n 0 -m slow tests/test_course_grading_stop.py
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
import requests
from course_procs import CourseServer, setup_class
from course_work import OFFICIAL, changed
from server_proc import ROBOKIT

pytestmark = pytest.mark.slow
SEEDS = 3


@pytest.fixture
def server(tmp_path: Path) -> Iterator[CourseServer]:
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    server = CourseServer(tmp_path / "data", workers=1, env={"TMPDIR": str(scratch)})
    server.tokens = setup_class(server, ["김민준"])  # type: ignore[attr-defined]
    official = tmp_path / "official.toml"
    official.write_text(OFFICIAL, encoding="utf-8")
    server.manage("create_assignment", "1반", "낙하", "--config", str(official), "--allow", "behaviour.duration",
                  "--seeds", f"0:{SEEDS}")
    yield server
    if server.proc is not None and server.proc.poll() is None:  # a test that failed half-way: nothing may outlive it
        server.stop()


def ours(server: CourseServer, log: list[str]) -> list[psutil.Process]:
    """Every process of this server still running: in the server's session or its worker's (the queue's processes
    rename themselves, but stay in their session) or working in the server's temporary folder (sandboxes, each in a
    session of its own)."""
    assert server.proc is not None
    sessions = {server.proc.pid, *(int(pid) for pid in re.findall(r"robokit worker, pid (\d+)", "".join(log)))}
    scratch = server.env["TMPDIR"]
    found = []
    for p in psutil.process_iter(["cwd", "status"]):
        if p.info["status"] == psutil.STATUS_ZOMBIE or p.pid == os.getpid():
            continue
        try:
            session = os.getsid(p.pid)
        except OSError:
            continue
        if session in sessions or (p.info["cwd"] or "").startswith(scratch):
            found.append(p)
    return found


def stopped_by(server: CourseServer, sig: signal.Signals, log: list[str]) -> float:
    """Send ``sig`` to the server; the seconds until it and everything of it ended."""
    assert server.proc is not None
    t0 = time.monotonic()
    server.proc.send_signal(sig)
    code = server.proc.wait(timeout=60)
    assert code in (0, 128 + sig), code
    psutil.wait_procs(ours(server, log), timeout=15)
    left = ours(server, log)
    assert not left, [(p.pid, p.name()) for p in left]
    return time.monotonic() - t0


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_serve_stops_at_any_moment_leaving_nothing(server: CourseServer, sig: signal.Signals) -> None:
    moments = {"starting": "robokit serve: database", "starting its worker": "evaluation worker (robokit worker",
               "idle": "Cluster"}
    for moment, line in moments.items():
        server.proc = subprocess.Popen([*ROBOKIT, "serve", "--data", str(server.data), "--port", str(server.port),
                                        "--workers", "1"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                       text=True, env=server.env, start_new_session=True)
        assert server.proc.stdout is not None
        seen = []
        for out in server.proc.stdout:
            seen.append(out)
            if line in out and (moment != "idle" or "running" in out):
                break
        took = stopped_by(server, sig, seen)
        server.proc.stdout.close()
        print(f"\n{sig.name} while {moment}: stopped in {took:.1f} s")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_stop_mid_evaluation_hands_the_submission_back(server: CourseServer, sig: signal.Signals) -> None:
    token = server.tokens["김민준"]  # type: ignore[attr-defined]
    server.start()
    resp = requests.post(f"{server.url}/api/robotics/assignments/낙하/submissions/", timeout=60,
                         json={"config": changed(OFFICIAL, duration="4.0")},
                         headers={"Authorization": f"Bearer {token}"})
    assert resp.status_code == 201, resp.text
    sandbox = "SELECT count(*) FROM course_submission WHERE status = 'running'"
    server.wait_for("the evaluation running", lambda: server.query(sandbox)[0][0] == 1, 120)
    scratch = server.env["TMPDIR"]
    server.wait_for("its sandbox started", lambda: any((p.info["cwd"] or "").startswith(scratch)
                                                       for p in ours(server, server.lines)), 60)
    took = stopped_by(server, sig, server.lines)
    (status, requeued, note), = server.query("SELECT status, requeued, note FROM course_submission")
    assert (status, requeued) == ("queued", 1)
    assert re.fullmatch(r"re-queued at \d\d:\d\d UTC: the worker evaluating it was stopped", note), note
    graded = server.query("SELECT seed, outcome, reason FROM course_result")
    assert all(outcome == "succeeded" for _, outcome, _ in graded), graded  # no trial graded by the stop
    print(f"\n{sig.name} mid-evaluation: stopped in {took:.1f} s, {len(graded)} of {SEEDS} trials kept")

    server.lines.clear()
    server.start()
    done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
    server.wait_for("the submission evaluated", lambda: server.query(done)[0][0] == 1, 180)
    assert server.stop() == []
    seeds = sorted(s for (s,) in server.query("SELECT seed FROM course_result"))
    assert seeds == list(range(SEEDS))  # each once
    assert server.query("SELECT trials, succeeded FROM course_submission") == [(SEEDS, SEEDS)]


def test_a_server_killed_alone_takes_its_worker_with_it(server: CourseServer) -> None:
    server.start()
    workers = [p for p in ours(server, server.lines) if p.pid != server.proc.pid]  # type: ignore[union-attr]
    assert len(workers) >= 4, workers  # robokit worker, the queue's sentinel, its process, monitor and pusher
    server.proc.kill()  # type: ignore[union-attr]
    server.proc.wait(timeout=30)  # type: ignore[union-attr]
    t0 = time.monotonic()
    gone, alive = psutil.wait_procs(workers, timeout=30)
    assert not alive, alive
    print(f"\nserver SIGKILLed: its worker's {len(gone)} processes ended {time.monotonic() - t0:.1f} s later")
