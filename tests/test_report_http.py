"""The http reporter against a real HTTP server on 127.0.0.1: retries, outbox, failed/, token hygiene."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from report_server import Answer, CourseServer, SilentListener, closed_port_url, make_payload, self_signed_cert
from robokit_plugins.http_report import HttpReportConfig, HttpReporter

from robokit.cli import main
from robokit.report.outbox import Outbox

FAST = {"retries": 2, "backoff_factor": 0.01, "backoff_max": 0.01, "backoff_jitter": 0.0, "read_timeout": 2.0}


def reporter(url: str, outbox: Path, **options: Any) -> HttpReporter:
    return HttpReporter("http", HttpReportConfig(url=url, outbox=str(outbox), **{**FAST, **options}))


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


def waiting(outbox: Path) -> list[str]:
    return [e.run_id for e in Outbox(outbox).entries()]


def test_payload_has_course_fields_at_top_level() -> None:
    p = make_payload(1, red_sorted=3, blue_sorted=2, failures=1, total_time=41.5, picks=[1, 2])
    assert (p["student"], p["project"], p["red_sorted"], p["blue_sorted"], p["failures"], p["total_time"]) == \
        ("kim", "A", 3, 2, 1, 41.5)
    assert p["result"]["picks"] == [1, 2] and "picks" not in p and p["schema"] == "robokit.run/1"


def test_2xx_is_delivered_once_with_the_run_id_as_idempotency_key(server: CourseServer, tmp_path: Path) -> None:
    payload = make_payload(1, red_sorted=3)
    d = reporter(server.url, tmp_path / "outbox").report(payload)
    assert d.delivered and d.stored is None and "HTTP 201" in d.message
    assert len(server.requests) == 1
    req = server.requests[0]
    assert req.path == "/api/robotics/result/" and req.key == payload["run_id"]
    assert req.headers["content-type"] == "application/json" and req.json() == payload
    assert "authorization" not in req.headers
    assert waiting(tmp_path / "outbox") == [] and Outbox(tmp_path / "outbox").failed() == []


def test_500_then_200_is_delivered_after_a_retry(server: CourseServer, tmp_path: Path) -> None:
    server.script(Answer(500, "boom"), Answer(200))
    payload = make_payload(2)
    d = reporter(server.url, tmp_path / "outbox").report(payload)
    assert d.delivered
    assert server.keys() == [payload["run_id"]] * 2
    assert waiting(tmp_path / "outbox") == []


def test_connection_refused_goes_to_the_outbox(tmp_path: Path) -> None:
    payload = make_payload(3)
    d = reporter(closed_port_url(), tmp_path / "outbox").report(payload)
    assert not d.delivered and d.stored is not None and "outbox" in d.message
    [entry] = Outbox(tmp_path / "outbox").entries()
    assert entry.run_id == payload["run_id"] and entry.payload == payload and entry.attempts == 1
    assert "Connection refused" in (entry.last_error or "")
    assert Path(d.stored) == entry.path


def test_read_timeout_goes_to_the_outbox(tmp_path: Path) -> None:
    silent = SilentListener()
    try:
        d = reporter(silent.url, tmp_path / "outbox", read_timeout=0.1, retries=1).report(make_payload(4))
    finally:
        silent.close()
    assert not d.delivered and d.stored is not None
    [entry] = Outbox(tmp_path / "outbox").entries()
    assert "read timeout" in (entry.last_error or "")


@pytest.mark.slow
def test_429_retry_after_is_honoured(server: CourseServer, tmp_path: Path) -> None:
    server.script(Answer(429, "slow down", headers=(("Retry-After", "1"),)), Answer(201))
    d = reporter(server.url, tmp_path / "outbox").report(make_payload(5))
    assert d.delivered and len(server.requests) == 2
    gap = server.requests[1].at - server.requests[0].at
    assert gap >= 0.95, f"the retry came {gap:.3f} s after a 429 with Retry-After: 1"  # backoff alone: 0.01 s


def test_400_moves_the_entry_to_failed_with_the_servers_answer(
    server: CourseServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    server.script(Answer(400, '{"student": ["This field is required."]}'))
    payload = make_payload(6)
    d = reporter(server.url, tmp_path / "outbox").report(payload)
    assert not d.delivered and len(server.requests) == 1  # a 400 is not retried
    assert waiting(tmp_path / "outbox") == []
    [failed] = Outbox(tmp_path / "outbox").failed()
    assert failed.path.parent.name == "failed" and Path(d.stored or "") == failed.path
    assert failed.data["server_answer"]["status"] == 400
    assert "This field is required." in failed.data["server_answer"]["body"]
    assert failed.payload == payload
    assert main(["outbox", "list", "--failed", "--dir", str(tmp_path / "outbox")]) == 0
    assert "HTTP 400: {\"student\": [\"This field is required.\"]}" in capsys.readouterr().out


def test_an_unwritable_outbox_does_not_stop_a_delivery(server: CourseServer, tmp_path: Path) -> None:
    (tmp_path / "blocker").write_text("a file where the outbox folder should be")
    d = reporter(server.url, tmp_path / "blocker" / "outbox").report(make_payload(17))
    assert d.delivered and server.keys() == [make_payload(17)["run_id"]]


def test_payload_over_the_size_limit_is_not_sent(server: CourseServer, tmp_path: Path) -> None:
    d = reporter(server.url, tmp_path / "outbox", max_payload_bytes=200).report(make_payload(7, log="x" * 500))
    assert not d.delivered and server.requests == []
    [failed] = Outbox(tmp_path / "outbox").failed()
    assert "max_payload_bytes" in failed.data["last_error"]


def _all_text(root: Path) -> str:
    return "\n".join(p.read_text(encoding="utf-8", errors="replace") for p in root.rglob("*") if p.is_file())


def test_token_is_sent_as_a_header_and_written_nowhere(
    server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    secret = "s3cr3t-token-value-81f2"
    monkeypatch.setenv("ROBOKIT_TEST_TOKEN", secret)
    monkeypatch.chdir(tmp_path)
    # first try: 503 until retries run out -> outbox; the server's error page echoes the token back
    server.script(*[Answer(503, f"bad gateway, you sent Bearer {secret}")] * 3)
    d = reporter(server.url, tmp_path / "outbox", token_env="ROBOKIT_TEST_TOKEN", retries=2).report(make_payload(8))
    assert not d.delivered and secret not in d.message
    # a 400 that echoes the token, for another run -> failed/
    server.script(Answer(400, f"token {secret} not allowed for this project"))
    reporter(server.url, tmp_path / "outbox", token_env="ROBOKIT_TEST_TOKEN").report(make_payload(9))
    # the flush re-reads the token from the environment
    assert main(["outbox", "list", "--dir", str(tmp_path / "outbox")]) == 0
    assert main(["outbox", "flush", "--dir", str(tmp_path / "outbox")]) == 0
    auth = {r.headers.get("authorization") for r in server.requests}
    assert auth == {f"Bearer {secret}"} and len(server.requests) == 3 + 1 + 1
    assert waiting(tmp_path / "outbox") == []
    out = capsys.readouterr()
    assert secret not in out.out + out.err + d.message
    assert secret not in _all_text(tmp_path)
    assert "***" in _all_text(tmp_path / "outbox" / "failed")


def test_a_named_token_variable_that_is_unset_is_refused_never_sent_without_it(
    server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("ROBOKIT_TEST_TOKEN", raising=False)
    d = reporter(server.url, tmp_path / "outbox", token_env="ROBOKIT_TEST_TOKEN").report(make_payload(10))
    assert not d.delivered and server.requests == []
    assert Outbox(tmp_path / "outbox").entries() == []
    [entry] = Outbox(tmp_path / "outbox").failed()
    assert "ROBOKIT_TEST_TOKEN is not set" in (entry.last_error or "")
    assert "export ROBOKIT_TEST_TOKEN=" in entry.data["advice"] and "robokit outbox retry" in entry.data["advice"]


@pytest.mark.parametrize(("http_table", "expected"), [
    ('url = "http://127.0.0.1:9/"\ntoken = "hunter2-xyz"', "token_env"),
    ('url = "http://127.0.0.1:9/"\ntoken_env = "hunter2-xyz=="', "NAME of an environment variable"),
    ("retries = 1", "--report-url"),
])
def test_http_config_errors_are_one_line_and_never_echo_a_token(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], http_table: str, expected: str
) -> None:
    cfg = tmp_path / "c.toml"
    cfg.write_text(f"[world]\nmax_time = 0.1\n[report.http]\n{http_table}\n")
    assert main(["validate", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "report.http" in err and expected in err
    assert "hunter2" not in err


def test_tls_is_verified_by_default(tmp_path: Path) -> None:
    cert, key = self_signed_cert(tmp_path)
    server = CourseServer(tls=(cert, key)).start()
    try:
        untrusted = reporter(server.url, tmp_path / "outbox", retries=0).report(make_payload(15))
        trusted = reporter(server.url, tmp_path / "outbox", retries=0, verify=cert).report(make_payload(16))
    finally:
        server.stop()
    assert not untrusted.delivered and trusted.delivered
    [entry] = Outbox(tmp_path / "outbox").entries()
    assert entry.run_id == make_payload(15)["run_id"] and "TLS error" in (entry.last_error or "")
    assert "certificate verify failed" in (entry.last_error or "")
    assert server.keys() == [make_payload(16)["run_id"]]


def test_after_delivering_its_own_result_the_reporter_flushes_the_outbox(
    server: CourseServer, tmp_path: Path
) -> None:
    box = tmp_path / "outbox"
    server.script(Answer(503), Answer(503))
    reporter(server.url, box, retries=0).report(make_payload(11))
    reporter(server.url, box, retries=0).report(make_payload(12))
    reporter(closed_port_url(), box, retries=0).report(make_payload(14))  # for another server: left alone
    assert len(waiting(box)) == 3
    d = reporter(server.url, box).report(make_payload(13))
    assert d.delivered and "2 delivered" in d.message
    ids = [make_payload(i)["run_id"] for i in (11, 12, 13, 14)]
    assert server.keys() == [ids[0], ids[1], ids[2], ids[0], ids[1]]  # own first, then the oldest first
    assert waiting(box) == [ids[3]]
    assert json.loads(json.dumps(server.stored))  # every stored payload is plain JSON
