"""The outbox on disk and its commands: list, flush oldest first, failed/, file locks, concurrent flushes."""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from report_server import Answer, CourseServer, closed_port_url
from robokit_plugins.http_report import HttpOptions, HttpSender
from robokit_plugins.local_report import LocalReportConfig, LocalReporter
from test_report_http import make_payload

from robokit.cli import main
from robokit.report.outbox import Outbox
from robokit.report.reporting import write_json_atomic

OPTS = HttpOptions(retries=0, backoff_factor=0.0, backoff_jitter=0.0).to_dict()


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


def fill(box: Outbox, url: str, ids: range, *, created0: float = 1_700_000_000.0) -> list[str]:
    """Put entries whose creation times increase with ``ids`` but are written in reverse order."""
    run_ids = []
    for i in reversed(ids):
        entry = box.put(make_payload(i), url, OPTS)
        write_json_atomic(entry.path, {**entry.data, "created_at": created0 + i}, overwrite=True)
        run_ids.append(entry.run_id)
    return run_ids[::-1]


def flush(box: Path, *extra: str) -> int:
    return main(["outbox", "flush", "--dir", str(box), *extra])


def test_list_shows_run_id_age_attempts_and_last_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    box = Outbox(tmp_path / "outbox")
    [rid] = fill(box, closed_port_url(), range(1))
    assert flush(box.root) == 1
    capsys.readouterr()
    assert main(["outbox", "list", "--dir", str(box.root)]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith(rid))
    assert "Connection refused" in row and " 1 " in row and ("d" in row.split()[3])  # age: days old
    assert row.split()[1:3] == ["waiting", "yours"]  # made and listed without a token
    assert "1 waiting" in out and "0 refused" in out
    assert main(["outbox", "list", "--dir", str(box.root), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["waiting"][0]["run_id"] == rid and data["waiting"][0]["attempts"] == 1


def test_flush_delivers_oldest_first_and_empties_the_outbox(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(5))
    assert flush(box.root) == 0
    assert server.keys() == ids
    assert box.entries() == [] and box.failed() == []
    assert not list(box.root.glob(".*.tmp"))


def test_a_5xx_keeps_the_entry_and_stops_the_flush(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(3))
    server.script(Answer(201), Answer(503, "maintenance"))
    assert flush(box.root) == 1
    assert server.keys() == ids[:2]  # the third was not tried: order is kept
    left = box.entries()
    assert [e.run_id for e in left] == ids[1:]
    assert left[0].attempts == 1 and "503" in (left[0].last_error or "") and left[1].attempts == 0
    assert flush(box.root) == 0 and server.keys() == ids[:2] + ids[1:]


def test_flush_url_overrides_the_entrys_url(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, closed_port_url(), range(2))
    assert flush(box.root, "--url", server.url) == 0
    assert server.keys() == ids


def test_a_4xx_moves_the_entry_to_failed_and_the_flush_goes_on(
    server: CourseServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(3))
    server.script(Answer(201), Answer(422, '{"project": ["must be A or B"]}'))
    assert flush(box.root) == 1
    assert server.keys() == ids and box.entries() == []
    [failed] = box.failed()
    assert failed.run_id == ids[1] and failed.data["server_answer"]["status"] == 422
    assert "must be A or B" in failed.data["server_answer"]["body"]
    assert "refused" in capsys.readouterr().out
    server.script(Answer(408), then=Answer(429))  # 408 and 429 are not refusals: the entry keeps waiting
    box.put(make_payload(9), server.url, OPTS)
    assert flush(box.root) == 1 and [e.run_id for e in box.entries()] == [make_payload(9)["run_id"]]


def test_an_entry_whose_lock_is_held_is_skipped_not_sent(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(3))
    held = box.lock(ids[1], timeout=0)
    with held:  # as if another flush (or the run itself) were sending it right now
        report = box.flush(HttpSender())
    assert report.busy == [ids[1]] and report.delivered == [ids[0], ids[2]]
    assert server.keys() == [ids[0], ids[2]]
    assert box.flush(HttpSender()).delivered == [ids[1]]


def test_a_flush_started_while_another_is_sending_skips_its_entry(server: CourseServer, tmp_path: Path) -> None:
    """Flush B starts while flush A's first POST is at the server: B skips that entry, A skips what B sent."""
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(4))
    second: list[Any] = []

    def start_b_during_first_request(rec: Any) -> None:
        if not second:
            second.append(None)
            second[0] = Outbox(box.root).flush(HttpSender())

    server.on_request = start_b_during_first_request
    first = box.flush(HttpSender())
    assert first.delivered == [ids[0]] and second[0].busy == [ids[0]] and second[0].delivered == ids[1:]
    assert sorted(server.keys()) == sorted(ids)  # raw count: one request per entry


def test_two_flushes_at_once_never_send_an_entry_twice(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    ids = fill(box, server.url, range(40))
    go = threading.Barrier(2)
    reports: list[Any] = []

    def worker() -> None:
        go.wait()
        reports.append(Outbox(box.root).flush(HttpSender()))

    threads = [threading.Thread(target=worker) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(server.keys()) == sorted(ids)  # raw count: 40 requests for 40 entries
    assert sorted(reports[0].delivered + reports[1].delivered) == sorted(ids) and box.entries() == []


def test_local_reporter_never_overwrites_an_earlier_result(tmp_path: Path) -> None:
    rep = LocalReporter("local", LocalReportConfig(dir=str(tmp_path / "results")))
    payload = make_payload(1)
    first = rep.report(payload)
    second = rep.report({**payload, "outcome": "failed"})
    assert first.delivered and not second.delivered and "already exists" in second.message
    assert json.loads(Path(first.stored or "").read_text())["outcome"] == "succeeded"
    run_folder = tmp_path / "results" / payload["run_id"]
    assert [p.name for p in run_folder.iterdir()] == ["result.json"]  # no temp files
    if os.name == "posix":  # written through a new file only its owner can read, as tempfile.mkstemp makes them
        assert (run_folder / "result.json").stat().st_mode & 0o777 == 0o600
