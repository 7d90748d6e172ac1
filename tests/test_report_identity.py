"""An outbox entry belongs to whoever made it: two students' tokens on one machine, one outbox. A flush sends only
the entries made under the flusher's token (with that token) and leaves the others waiting with one line saying
whose they are; a flush uploads a run's files when its config asked. Against a real HTTP server on 127.0.0.1."""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from pathlib import Path

import pytest
from report_server import Answer, CourseServer, make_payload
from robokit_plugins.http_report import HttpReportConfig, HttpReporter

from robokit.cli import main
from robokit.report.outbox import Outbox

KIM, LEE = "rks_kim-token-0001", "rks_lee-token-0002"


def fp(token: str) -> str:  # the rule from the docs: sha256, first 12 hex digits
    return "sha256:" + hashlib.sha256(token.encode()).hexdigest()[:12]


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    return tmp_path


def report_while_down(server: CourseServer, i: int, token: str | None, monkeypatch, **options) -> str:
    """Report run ``i`` while the server answers 503 (no retries): the entry waits in ./outbox."""
    if token is None:
        monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    else:
        monkeypatch.setenv("ROBOKIT_TOKEN", token)
    server.script(Answer(503, store=False))
    cfg = HttpReportConfig(url=server.url, retries=0, backoff_jitter=0.0, **options)
    assert not HttpReporter("http", cfg).report(make_payload(i)).delivered
    return str(make_payload(i)["run_id"])


def test_each_students_flush_sends_only_their_own_runs(server, here, monkeypatch, capsys) -> None:
    kim = [report_while_down(server, i, KIM, monkeypatch) for i in (1, 3, 5)]
    lee = [report_while_down(server, i, LEE, monkeypatch) for i in (2, 4)]
    anon = report_while_down(server, 6, None, monkeypatch)
    assert {e.run_id: e.identity for e in Outbox("outbox").entries()} == {
        **dict.fromkeys(kim, fp(KIM)), **dict.fromkeys(lee, fp(LEE)), anon: "no token"}
    assert not [p for p in Path("outbox").rglob("*") if p.is_file() and KIM.encode() in p.read_bytes()]
    sent_before = len(server.requests)

    monkeypatch.setenv("ROBOKIT_TOKEN", KIM)
    assert main(["outbox", "flush"]) == 0
    out = capsys.readouterr().out
    new = server.requests[sent_before:]
    assert [r.key for r in new] == kim and {r.headers["authorization"] for r in new} == {f"Bearer {KIM}"}
    [line] = [x for x in out.splitlines() if x.startswith("left waiting")]
    assert f"2 made under token {fp(LEE)}" in line and "1 made without a token" in line
    assert "robokit outbox flush" in line
    assert sorted(e.run_id for e in Outbox("outbox").entries()) == sorted([*lee, anon])

    assert main(["outbox", "list"]) == 0
    rows = {x.split()[0]: x.split()[1:3] for x in capsys.readouterr().out.splitlines() if x.split()[0] in lee}
    assert rows == dict.fromkeys(lee, ["waiting", fp(LEE)])  # kim sees whose they are

    monkeypatch.setenv("ROBOKIT_TOKEN", LEE)
    sent_before = len(server.requests)
    assert main(["outbox", "flush"]) == 0
    new = server.requests[sent_before:]
    assert [r.key for r in new] == lee and {r.headers["authorization"] for r in new} == {f"Bearer {LEE}"}
    monkeypatch.delenv("ROBOKIT_TOKEN")
    assert main(["outbox", "flush"]) == 0
    assert server.requests[-1].key == anon and "authorization" not in server.requests[-1].headers
    assert server.store_count == dict.fromkeys([*kim, *lee, anon], 1)


def test_a_run_that_delivers_flushes_only_its_makers_entries(server, here, monkeypatch) -> None:
    lee = report_while_down(server, 7, LEE, monkeypatch)
    kim = report_while_down(server, 8, KIM, monkeypatch)
    monkeypatch.setenv("ROBOKIT_TOKEN", KIM)
    d = HttpReporter("http", HttpReportConfig(url=server.url, retries=0)).report(make_payload(9))
    assert d.delivered and "1 delivered" in d.message
    assert [r.key for r in server.requests[-2:]] == [make_payload(9)["run_id"], kim]
    assert [e.run_id for e in Outbox("outbox").entries()] == [lee]


def test_flush_uploads_the_runs_files_when_its_config_asked(server, here, monkeypatch, capsys) -> None:
    rid = report_while_down(server, 10, KIM, monkeypatch, upload_artifacts=True)
    plain = report_while_down(server, 11, KIM, monkeypatch)
    for run in (rid, plain):
        (here / "results" / run).mkdir(parents=True)
        (here / "results" / run / "trace.jsonl").write_text('{"kind": "header"}\n')
    assert main(["outbox", "flush"]) == 0
    uploads = [r for r in server.requests if r.path.endswith("/artifacts/")]
    assert [r.path for r in uploads] == [f"/api/robotics/result/{rid}/artifacts/"]
    assert uploads[0].headers["authorization"] == f"Bearer {KIM}" and b'filename="trace.jsonl"' in uploads[0].body
    assert "artifacts: 1/1 uploaded" in capsys.readouterr().out


def test_an_entry_from_before_identities_waits_until_claimed(server, here, monkeypatch, capsys) -> None:
    from robokit_plugins.http_report import HttpOptions

    from robokit.report.reporting import write_json_atomic

    box = Outbox("outbox")
    entry = box.put(make_payload(12), server.url, HttpOptions(token_env="ROBOKIT_TOKEN", retries=0).to_dict())
    old = {k: v for k, v in entry.data.items() if k != "identity"}  # as robokit wrote entries before
    write_json_atomic(entry.path, old, overwrite=True)
    monkeypatch.setenv("ROBOKIT_TOKEN", KIM)
    assert main(["outbox", "flush"]) == 0
    assert server.requests == [] and "--claim" in capsys.readouterr().out
    assert main(["outbox", "retry", entry.run_id]) == 1  # named, but not provably yours
    assert main(["outbox", "retry", entry.run_id, "--claim"]) == 0
    assert [r.headers["authorization"] for r in server.requests] == [f"Bearer {KIM}"]


def test_upload_artifacts_sends_the_token_in_robokit_token(server, here, monkeypatch) -> None:
    (here / "results" / "run-1").mkdir(parents=True)
    (here / "results" / "run-1" / "trace.jsonl").write_text('{"kind": "header"}\n')
    monkeypatch.setenv("ROBOKIT_TOKEN", KIM)
    assert main(["upload-artifacts", "run-1", "--url", server.url]) == 0
    [req] = server.requests
    assert req.path == "/api/robotics/result/run-1/artifacts/" and req.headers["authorization"] == f"Bearer {KIM}"
