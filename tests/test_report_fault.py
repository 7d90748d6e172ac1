"""Faults, crashes and whole runs: every result arrives, and a server honouring the key stores it once."""

from __future__ import annotations

import logging
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from report_server import Answer, CourseServer, Recorded, closed_port_url, make_payload
from robokit_plugins.http_report import HttpReportConfig, HttpReporter

from robokit.cli import main
from robokit.report.outbox import IN_FLIGHT, Outbox

DROP_TEST = Path(__file__).resolve().parents[1] / "configs" / "drop_test.toml"
FAULTY = {"retries": 1, "backoff_factor": 0.001, "backoff_max": 0.001, "backoff_jitter": 0.001,
          "connect_timeout": 1.0, "read_timeout": 0.3, "flush_outbox": False}


def faulty_plan(seed: int):  # type: ignore[no-untyped-def]
    """A server that refuses (TCP reset) 20 %, errors (5xx) 20 %, stalls 4 % (half after storing), else 201."""
    rng = np.random.default_rng(seed)

    def plan(n: int) -> Answer:
        u = rng.random()
        if u < 0.20:
            return Answer(reset=True)
        if u < 0.40:
            return Answer(int(rng.choice([500, 502, 503])), "down")
        if u < 0.44:
            return Answer(stall=True, store=bool(rng.random() < 0.5))
        return Answer(201)

    return plan


@pytest.mark.slow  # 200 runs: the slow tier
def test_200_runs_through_a_faulty_server_then_one_flush_arrive_exactly_once(tmp_path: Path) -> None:
    """Reporters do not flush after delivering here (tested elsewhere), so the final flush has real work. The
    figures go to a log record (pytest shows it with the failure, or with ``-o log_cli=true``)."""
    server = CourseServer(plan=faulty_plan(seed=6)).start()
    box = tmp_path / "outbox"
    try:
        cfg = HttpReportConfig(url=server.url, outbox=str(box), **FAULTY)
        payloads = [make_payload(i, red_sorted=i % 4, blue_sorted=i % 3) for i in range(200)]
        deliveries = [HttpReporter("http", cfg).report(p) for p in payloads]
        waiting_after_faults = len(Outbox(box).entries())
        server.plan = lambda n: Answer(201)
        assert main(["outbox", "flush", "--dir", str(box)]) == 0
    finally:
        server.stop()
    ids = {p["run_id"] for p in payloads}
    raw = Counter(server.keys())
    # every run id arrived, and was stored once (the server dedups by Idempotency-Key)
    assert set(server.stored) == ids and set(server.store_count.values()) == {1}
    # none was sent again after the server had answered 2xx for it: extra raw requests are only retries of
    # attempts that got no 2xx (reset, 5xx, stall) - at-least-once sending + the key = exactly-once storage
    assert [r.key for r in server.requests if r.after_ack] == []
    assert Outbox(box).entries() == [] and Outbox(box).failed() == []
    assert all(d.delivered or d.stored for d in deliveries)  # each run kept its result somewhere
    assert waiting_after_faults > 0  # the faults did push results into the outbox
    answers = Counter("reset" if r.answer.reset else "stall" if r.answer.stall else r.answer.status
                      for r in server.requests)
    logging.getLogger(__name__).info(
        "fault test: %d requests for %d runs (%d resends, all after an unanswered or failed try), %d in the outbox "
        "before the flush; answers %s", len(server.requests), len(ids), sum(raw.values()) - len(raw),
        waiting_after_faults, dict(answers))


@pytest.mark.slow
def test_a_run_killed_right_after_its_post_resends_with_the_same_key(tmp_path: Path) -> None:
    """The server stores the POST, then SIGKILLs the sending ``robokit run`` before it can answer."""
    procs: list[subprocess.Popen[bytes]] = []

    def kill_the_sender(rec: Recorded) -> None:
        if len(procs) == 1 and procs[0].poll() is None:
            procs[0].kill()
            procs[0].wait(30)

    server = CourseServer(on_request=kill_the_sender).start()
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "robokit.cli", "run", str(DROP_TEST), "--report-url", server.url,
             "--student", "kim", "--project", "A"], cwd=tmp_path, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL))
        procs[0].wait(120)
        assert procs[0].returncode == -9
        [entry] = Outbox(tmp_path / "outbox").entries()  # the write-ahead entry survived the crash
        rid = entry.run_id
        assert entry.attempts == 1 and entry.last_error == IN_FLIGHT
        assert (tmp_path / "results" / rid / "result.json").exists()
        assert main(["outbox", "flush", "--dir", str(tmp_path / "outbox")]) == 0
    finally:
        server.stop()
    assert server.keys() == [rid, rid]  # sent twice, with the same Idempotency-Key ...
    assert server.store_count == {rid: 1}  # ... and stored once
    assert Outbox(tmp_path / "outbox").entries() == []


def test_robokit_run_posts_the_payload_with_course_fields(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    server = CourseServer().start()
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["run", str(DROP_TEST), "--report-url", server.url, "--student", "kim", "--project", "A"])
    finally:
        server.stop()
    assert code == 0
    [req] = server.requests
    body = req.json()
    assert req.path == "/api/robotics/result/" and req.key == body["run_id"]
    assert (body["student"], body["project"], body["outcome"]) == ("kim", "A", "succeeded")
    assert body["schema"] == "robokit.run/1" and "bodies" in body["result"]
    out = capsys.readouterr().out
    assert "report[http]: delivered" in out and f"results/{body['run_id']}/result.json" in out
    assert not (tmp_path / "outbox").exists() or Outbox(tmp_path / "outbox").entries() == []


def _config_with(tmp_path: Path, report: str) -> Path:
    cfg = tmp_path / "drop.toml"
    cfg.write_text(DROP_TEST.read_text(encoding="utf-8") + "\n" + report, encoding="utf-8")
    return cfg


def test_an_undelivered_result_goes_to_the_outbox_and_the_run_still_succeeds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    cfg = _config_with(tmp_path, f'[report.http]\nurl = "{closed_port_url()}"\nretries = 0\n')
    assert main(["run", str(cfg)]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("report[http]"))
    assert "not delivered" in line and "kept in the outbox" in line and "robokit outbox flush" in line
    assert len(Outbox(tmp_path / "outbox").entries()) == 1


def test_exit_code_4_only_when_the_result_is_kept_nowhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "blocker").write_text("a file where folders should be")
    cfg = _config_with(tmp_path, f'[report.local]\ndir = "blocker/results"\n[report.http]\n'
                                 f'url = "{closed_port_url()}"\nretries = 0\noutbox = "blocker/outbox"\n')
    assert main(["run", str(cfg)]) == 4
    out = capsys.readouterr().out
    assert "outcome: succeeded" in out and "could not be delivered or stored anywhere" in out
