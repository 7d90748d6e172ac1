"""End to end: ``robokit serve`` as a process on 127.0.0.1, real ``robokit run configs/sort_robot.toml
--report-url`` processes posting to it (one while the server is down, delivered later by ``robokit outbox flush``),
and the teacher's leaderboard showing every run exactly once."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from server_proc import ROBOKIT, Server, free_port, robokit, teacher_session

ROOT = Path(__file__).resolve().parents[1]
CONFIG = str(ROOT / "configs" / "sort_robot.toml")
PASSWORD = "e2e-teacher-pass"


def _run_id(proc: subprocess.CompletedProcess[str]) -> str:
    run_id: str = json.loads(proc.stdout)["run_id"]
    return run_id


@pytest.mark.slow
def test_runs_reach_the_served_leaderboard_exactly_once(tmp_path: Path) -> None:
    data, port = tmp_path / "srv", free_port()
    url = f"http://127.0.0.1:{port}/api/robotics/result/"
    env = {"ROBOKIT_TEACHER_PASSWORD": PASSWORD}
    made = robokit("serve", "--data", str(data), "--create-teacher", "teacher", cwd=tmp_path, env=env)
    assert "teacher 'teacher' created" in made.stdout
    robokit("manage", "--data", str(data), "create_class", "1반", "--teacher", "teacher", "--allow-unverified",
            cwd=tmp_path)
    added = robokit("manage", "--data", str(data), "add_students", "1반", "김민준", cwd=tmp_path)
    token = added.stdout.strip().split("\t")[1]

    # 1. A student runs while the server is down: the result waits in their outbox.
    alice = tmp_path / "alice"
    alice.mkdir()
    down = robokit("run", CONFIG, "--json", "--quiet", "--report-url", url, "--student", "alice", "--project", "A",
                   cwd=alice)
    first = _run_id(down)
    assert [p.name for p in (alice / "outbox").glob("*.json")] == [f"{first}.json"]

    server = Server(data, port).start()
    try:
        assert f"SQLite {data / 'db.sqlite3'}" in server.log
        # 2. Two students run at once against the live server: one as lesson 08 does (no token), one with a
        #    token from their own copy of the config (token_env + upload_artifacts).
        bob, kim = tmp_path / "bob", tmp_path / "kim"
        bob.mkdir()
        kim.mkdir()
        kim_config = kim / "sort_robot.toml"
        kim_config.write_text(Path(CONFIG).read_text(encoding="utf-8") + '\n[report.http]\nurl = "' + url
                              + '"\ntoken_env = "ROBOKIT_TOKEN"\nupload_artifacts = true\n', encoding="utf-8")
        procs = [
            subprocess.Popen([*ROBOKIT, "run", CONFIG, "--json", "--report-url", url, "--student", "bob",
                              "--project", "A"], cwd=bob, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True),
            subprocess.Popen([*ROBOKIT, "run", str(kim_config), "--json", "--student", "someone else",
                              "--project", "A"], cwd=kim, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**server.env, "ROBOKIT_TOKEN": token}),
        ]
        outs = [p.communicate(timeout=600) for p in procs]
        assert [p.returncode for p in procs] == [0, 0], outs
        second, third = (json.loads(o[0])["run_id"] for o in outs)
        assert "report[http]: delivered" in outs[0][1] and "(HTTP 201)" in outs[0][1]
        uploaded = re.search(r"artifacts: (\d+)/(\d+) uploaded", outs[1][1])
        assert uploaded is not None and uploaded.group(1) == uploaded.group(2), outs[1][1]  # trace.jsonl + config

        # 3. Alice flushes her outbox; a copy of the entry sent again later is answered 200, not stored twice.
        entry = (alice / "outbox" / f"{first}.json").read_text(encoding="utf-8")
        flushed = robokit("outbox", "flush", cwd=alice)
        assert "delivered" in flushed.stdout + flushed.stderr
        assert not list((alice / "outbox").glob("*.json"))
        (alice / "outbox" / f"{first}.json").write_text(entry, encoding="utf-8")
        robokit("outbox", "flush", cwd=alice)

        # 4. The teacher's leaderboard shows each run exactly once.
        session = teacher_session(server.url, "teacher", PASSWORD)
        room = session.get(f"{server.url}/", timeout=30).text
        class_url = re.search(r'href="(/classes/\d+/)"', room)
        assert class_url is not None
        page = session.get(server.url + class_url.group(1), timeout=30).text
        board_url = re.search(r'href="(/classes/\d+/projects/\d+/)">A<', page)
        assert board_url is not None
        board = session.get(server.url + board_url.group(1), timeout=30).text
        for run_id in (first, second, third):
            assert board.count(f'href="/runs/{run_id}/"') == 1, run_id
        verified = board[board.index('id="students"'):board.index('id="unverified"')]
        assert "김민준" in verified and "someone else" not in verified and f"/runs/{third}/" in verified
        unverified = board[board.index('id="unverified"'):]
        assert "alice" in unverified and "bob" in unverified
        csv_text = session.get(server.url + class_url.group(1) + "results.csv", timeout=30).text
        assert len(csv_text.strip().splitlines()) == 1 + 3
        run_page = session.get(f"{server.url}/runs/{third}/", timeout=30).text
        assert "[sensors.camera]" in run_page  # the uploaded config's text
        assert "PICK_PLACE" in run_page and 'class="seg' in run_page  # the state timeline from the run's trace
        assert token not in server.log and token not in board + run_page
    finally:
        code = server.stop()
    assert code == 0 and "stopped" in server.log
    assert server.log.count("POST /api/robotics/result/ 201") == 3
    shutil.rmtree(data / "media", ignore_errors=True)


@pytest.mark.slow
def test_concurrent_posters_store_every_result_exactly_once() -> None:
    """benchmarks/server_load.py, small: 5 clients x 20 posts (every 10th resent) against robokit serve."""
    import sys

    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "server_load.py"), "--clients", "5",
                           "--posts", "20"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "stored: 120 rows for 120 distinct runs" in proc.stdout and "every result exactly once" in proc.stdout
    assert "journal_mode=wal" in proc.stdout
