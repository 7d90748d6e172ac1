"""Delivery promises, counted at a real loopback server: 408 and 429 are retried (the 429 is really reached), the
number of retries is what was configured, 5xx and redirects keep the entry waiting, attempts are counted, the flush
goes oldest first and stops only for the server that is down, ``--url`` picks that server's entries."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from report_server import Answer, CourseServer
from robokit_plugins.http_report import HttpOptions, HttpSender
from test_report_http import make_payload

from robokit.report.outbox import Outbox
from robokit.report.reporting import write_json_atomic


def opts(retries: int) -> dict:
    return HttpOptions(retries=retries, backoff_factor=0.0, backoff_jitter=0.0).to_dict()


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


@pytest.fixture
def other() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


def put(box: Outbox, url: str, i: int, retries: int = 0, created: float | None = None) -> str:
    entry = box.put(make_payload(i), url, opts(retries))
    if created is not None:
        write_json_atomic(entry.path, {**entry.data, "created_at": created}, overwrite=True)
    return entry.run_id


def statuses(srv: CourseServer) -> list[int]:
    return [r.answer.status for r in srv.requests]


def test_408_then_429_are_retried_and_the_third_try_delivers(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    rid = put(box, server.url, 1, retries=2)
    server.script(Answer(408), Answer(429), then=Answer(201))
    report = box.flush(HttpSender())
    assert statuses(server) == [408, 429, 201]  # the 429 was reached, and retried
    assert report.delivered == [rid] and box.entries() == [] and box.failed() == []


def test_a_429_after_the_last_retry_keeps_the_entry_waiting(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    rid = put(box, server.url, 2, retries=1)
    server.script(Answer(408), then=Answer(429))
    report = box.flush(HttpSender())
    assert statuses(server) == [408, 429]
    assert report.waiting == [rid] and box.failed() == []
    [entry] = box.entries()
    assert "429" in entry.data["last_error"] and entry.attempts == 1


@pytest.mark.parametrize("retries", [0, 1, 3])
def test_a_server_error_is_tried_exactly_retries_plus_one_times(server: CourseServer, tmp_path: Path,
                                                                retries: int) -> None:
    box = Outbox(tmp_path / "outbox")
    rid = put(box, server.url, 3, retries=retries)
    server.script(then=Answer(503, "busy"))
    box.flush(HttpSender())
    assert statuses(server) == [503] * (retries + 1)
    [entry] = box.entries()
    assert entry.run_id == rid and entry.attempts == 1 and box.failed() == []  # 5xx may pass: kept, not refused
    box.flush(HttpSender())
    assert box.entries()[0].attempts == 2 and len(server.requests) == 2 * (retries + 1)


def test_a_redirect_keeps_the_entry_waiting(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    rid = put(box, server.url, 4)
    server.script(then=Answer(301, "", headers=(("Location", "https://elsewhere.example/api/"),)))
    report = box.flush(HttpSender())
    assert report.waiting == [rid] and box.failed() == []
    assert "redirects" in box.entries()[0].data["last_error"]


def test_a_refusal_moves_the_entry_to_failed(server: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    rid = put(box, server.url, 5)
    server.script(then=Answer(422, '{"student": ["missing"]}'))
    report = box.flush(HttpSender())
    assert report.failed == [rid] and box.entries() == [] and box.failed()[0].run_id == rid


def test_flush_is_oldest_first_and_stops_only_for_the_server_that_is_down(
        server: CourseServer, other: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    down1 = put(box, server.url, 10, created=1_700_000_003.0)
    up1 = put(box, other.url, 11, created=1_700_000_001.0)
    down2 = put(box, server.url, 12, created=1_700_000_004.0)
    up2 = put(box, other.url, 13, created=1_700_000_002.0)
    server.script(then=Answer(503))
    report = box.flush(HttpSender())
    assert other.keys() == [up1, up2]  # oldest first
    assert report.delivered == [up1, up2] and report.waiting == [down1] and report.not_tried == [down2]
    assert server.keys() == [down1]


def test_flush_with_a_url_sends_only_that_servers_entries(
        server: CourseServer, other: CourseServer, tmp_path: Path) -> None:
    box = Outbox(tmp_path / "outbox")
    mine = put(box, server.url, 20)
    theirs = put(box, other.url, 21)
    report = box.flush(HttpSender(), url=server.url)
    assert report.delivered == [mine] and server.keys() == [mine] and other.keys() == []
    assert [e.run_id for e in box.entries()] == [theirs]
