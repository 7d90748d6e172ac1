"""The result first: concurrent ``robokit outbox flush`` processes that each delivered what they took exit 0 and
send every entry exactly once; lock files that killed senders left behind are removed; a run with ``--no-record``
is named as the cause when a command needs its record."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest
from report_server import CourseServer
from robokit_plugins.http_report import HttpOptions
from test_report_http import make_payload

from robokit.cli import main
from robokit.report.outbox import Outbox

OPTS = HttpOptions(retries=0, backoff_factor=0.0, backoff_jitter=0.0).to_dict()
ROBOKIT = [sys.executable, "-c", "import sys; from robokit.cli import main; sys.exit(main())"]


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


@pytest.mark.slow
def test_three_flushes_at_once_each_exit_0_and_send_every_entry_once(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = [box.put(make_payload(i), server.url, OPTS).run_id for i in range(12)]
    procs = [subprocess.Popen(ROBOKIT + ["outbox", "flush", "--dir", str(box.root)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(3)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], outs
    assert Counter(server.keys()) == Counter(dict.fromkeys(ids, 1))  # the server's count: each entry once
    delivered = [int(out.rsplit(": ", 1)[1].split(" delivered")[0]) for out, _ in outs]
    assert sum(delivered) == len(ids) and box.entries() == []


def test_lock_files_of_killed_senders_are_removed(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    settled = [make_payload(i)["run_id"] for i in range(3)]  # delivered, but the sender died holding the lock
    waiting = box.put(make_payload(9), server.url, OPTS).run_id
    holder = ("import sys, time\nfrom filelock import FileLock\nlocks = [FileLock(p) for p in sys.argv[1:]]\n"
              "[lock.acquire() for lock in locks]\nprint('held', flush=True)\ntime.sleep(600)\n")
    proc = subprocess.Popen([sys.executable, "-c", holder, *(str(box.locks_dir / f"{r}.lock") for r in settled)],
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline() == "held\n"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert sorted(p.stem for p in box.locks_dir.glob("*.lock")) == sorted(settled)
    assert main(["outbox", "flush", "--dir", str(box.root)]) == 0
    assert server.keys() == [waiting]
    assert list(box.locks_dir.glob("*.lock")) == []  # the dead senders' locks and the flushed entry's went


def test_a_lock_a_live_sender_holds_is_kept_and_its_entry_left_to_it(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    run_id = box.put(make_payload(1), server.url, OPTS).run_id
    with box.lock(run_id, timeout=0):  # the run itself is sending it
        assert box.sweep_locks() == []
        assert main(["outbox", "flush", "--dir", str(box.root)]) == 0  # it took nothing; nothing it took failed
    assert server.keys() == [] and (box.locks_dir / f"{run_id}.lock").exists()


def test_a_record_command_after_no_record_names_the_option(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "scene.toml").write_text('[world]\nmax_time = 0.2\n[bodies.plane]\nurdf = "plane.urdf"\n'
                                         'position = [0, 0, 0]\n[behaviour]\ntype = "record"\ncomponents = []\n'
                                         'duration = 0.1\n')
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["run", "scene.toml", "--no-record", "--quiet"]) == 0
        for command in (["video", "last"], ["view", "last"], ["plot", "last"], ["export", "last", "--mcap", "x"]):
            capsys.readouterr()
            assert main(command) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and "it ran with --no-record" in err[0] and "without --no-record" in err[0], command
    finally:
        os.chdir(cwd)


def test_a_refused_report_is_one_line_without_the_server_s_raw_json(server: CourseServer, tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch,
                                                                    capsys: pytest.CaptureFixture) -> None:
    import json

    from report_server import Answer

    server.script(Answer(401, json.dumps({"error": "no token sent: this class needs a student's token",
                                          "field": "Authorization"}), store=False))
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    monkeypatch.chdir(tmp_path)
    config = Path(__file__).resolve().parents[1] / "configs" / "drop_test.toml"
    assert main(["run", str(config), "--report-url", server.url, "--set", "behaviour.duration=0.2"]) == 5
    captured = capsys.readouterr()
    said = [line for line in (captured.out + captured.err).splitlines() if "401" in line or "refused" in line.lower()]
    assert len(said) == 1 and said[0].startswith("robokit: error: report[http] refused (HTTP 401): no token sent")
    assert "{" not in said[0]


def test_a_payload_names_no_folder_of_the_machine_that_made_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.core.result import RunResult
    from robokit.report.reporting import build_payload

    monkeypatch.chdir(tmp_path)
    home, venv = str(Path.home()), sys.prefix
    result = RunResult(run_id="r1", robokit_version="0", config=str(tmp_path / "configs" / "a.toml"), behaviour=None,
                       seed=1, outcome="error", reason=f"cannot read {tmp_path}/meshes/arm.obj nor {venv}/x.urdf",
                       ticks=0, sim_time=0.0, wall_time=0.0, started_at="", warnings=[f"{home}/cache is full"])
    payload = build_payload(result)
    text = json.dumps(payload)
    assert str(tmp_path) not in text and venv not in text and f"{home}/" not in text
    assert payload["config"] == "configs/a.toml" and payload["reason"].startswith("cannot read meshes/arm.obj nor ")
    outside = build_payload(RunResult(**{**result.to_dict(), "config": "/elsewhere/b.toml"}))
    assert outside["config"] == "b.toml"
