"""The outbox's promises as properties over generated queues, judged at real loopback servers and on disk.

docs/reporting.md: a flush delivers the oldest entry first; a 2xx deletes the entry; a 4xx other than 408/429 moves
it to ``failed/`` with the server's answer and blocks nothing; anything that may pass (5xx, 408, 429, a dropped
connection) keeps it waiting with the error, and the later entries for *that* server wait (``--keep-going``: tried
anyway) while other servers' entries are still sent; every attempt is counted in the entry; a sender killed at any
point leaves the entry, and the next flush sends it again with the same ``Idempotency-Key``; the server, which
stores one result per key, ends with every result exactly once.

The oracle is a plain walk of the queue written here (sorted by creation time, one "down" set per server), the
servers' own records of what arrived (keys, bodies, order) and the outbox files read back.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer, make_payload
from robokit_plugins.http_report import HttpOptions, HttpSender

from robokit.report.outbox import IN_FLIGHT, Outbox, SendResult
from robokit.report.reporting import write_json_atomic

pytest_plugins = ["report_props"]

OPTS = HttpOptions(retries=0, backoff_factor=0.0, backoff_jitter=0.0).to_dict()
OK = (200, 201, 202)
REFUSE = (400, 401, 403, 404, 409, 422)
TRANSIENT = (408, 429, 500, 502, 503, "reset")
SETTINGS = settings(max_examples=6, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])

IDS = itertools.count(1)
"""Run ids never reused between examples (a server thread may still be settling the last one's request)."""


@pytest.fixture
def servers() -> Iterator[list[CourseServer]]:
    pair = [CourseServer().start(), CourseServer().start()]
    yield pair
    for s in pair:
        s.stop()


def answer_for(kind: Any) -> Answer:
    if kind == "reset":
        return Answer(reset=True, store=False)
    if kind in OK:
        return Answer(status=kind)
    return Answer(status=kind, body=json.dumps({"error": f"said {kind}"}), store=False)


def keyed_server(server: CourseServer, answers: dict[str, list[Any]]) -> None:
    """Reset ``server`` and answer by key (the plan sees the request through a wrapped ``_record``)."""
    server.requests.clear()
    server.stored.clear()
    server.store_count.clear()
    server.acked.clear()
    server.on_request = None
    tried: dict[str, int] = {}
    original = CourseServer._record

    def record(path: str, headers: dict[str, str], body: bytes, clock: float) -> Any:
        key = headers.get("idempotency-key") or ""
        n = tried.get(key, 0)
        tried[key] = n + 1
        script = answers.get(key, [])
        answer = answer_for(script[n]) if n < len(script) else Answer()
        server.plan = lambda _n: answer
        return original(server, path, headers, body, clock)

    server._record = record  # type: ignore[method-assign]


queues = st.lists(
    st.tuples(st.integers(0, 1),  # which server the entry was made for
              st.integers(0, 50),  # its creation time (ties broken by run id)
              st.lists(st.sampled_from(OK + REFUSE + TRANSIENT), max_size=1)  # first answer, then...
              .flatmap(lambda first: st.lists(st.sampled_from(OK + TRANSIENT), max_size=2).map(
                  lambda later: first + later))),  # ...answers that may pass, then 201
    min_size=1, max_size=5)


def expected_flush(order: list[tuple[str, int, Any]], keep_going: bool) -> dict[str, list[str]]:
    """The flush the docs describe, walked plainly: (run id, server, first answer) oldest first."""
    out: dict[str, list[str]] = {"delivered": [], "failed": [], "waiting": [], "not_tried": []}
    down: set[int] = set()
    for rid, srv, first in order:
        if not keep_going and srv in down:
            out["not_tried"].append(rid)
        elif first in OK:
            out["delivered"].append(rid)
        elif first in REFUSE:
            out["failed"].append(rid)
        else:
            out["waiting"].append(rid)
            down.add(srv)
    return out


@SETTINGS
@given(queue=queues, keep_going=st.booleans())
def test_a_flush_walks_the_queue_oldest_first_and_settles_each_entry_as_the_docs_say(
        servers: list[CourseServer], folders: Any, queue: list[Any],
        keep_going: bool) -> None:
    box = Outbox(folders())
    made: list[tuple[float, str, int, list[Any]]] = []
    bodies: dict[str, Any] = {}
    for i, (srv, created, answers) in enumerate(queue):
        entry = box.put(make_payload(next(IDS), red_sorted=i), servers[srv].url, OPTS)
        write_json_atomic(entry.path, {**entry.data, "created_at": 1_700_000_000.0 + created}, overwrite=True)
        made.append((1_700_000_000.0 + created, entry.run_id, srv, answers))
        bodies[entry.run_id] = entry.payload
    for n, s in enumerate(servers):
        keyed_server(s, {rid: ans for _, rid, srv, ans in made if srv == n})
    order = [(rid, srv, ans[0] if ans else 201) for _, rid, srv, ans in sorted(made)]
    want = expected_flush(order, keep_going)

    report = box.flush(HttpSender(), stop_on_transient=not keep_going)
    assert {k: getattr(report, k) for k in want} == want
    assert report.clean == (not (want["failed"] or want["waiting"] or want["not_tried"]))
    tried = [rid for rid, _, _ in order if rid not in want["not_tried"]]
    for n, s in enumerate(servers):  # each server saw its tried entries once each, oldest first, with their bodies
        assert s.keys() == [rid for rid in tried if dict((r, v) for r, v, _ in order)[rid] == n]
        for rec in s.requests:
            assert json.loads(rec.body)["run_id"] == rec.key
            assert rec.headers["content-type"] == "application/json"
    # on disk: delivered gone; refused in failed/ with the server's answer; the rest waiting, attempts counted
    waiting = {e.run_id: e for e in box.entries()}
    failed = {e.run_id: e for e in box.failed()}
    assert sorted(waiting) == sorted(want["waiting"] + want["not_tried"])
    assert sorted(failed) == sorted(want["failed"])
    first = {rid: a for rid, _, a in order}
    for rid, e in failed.items():
        assert e.data["server_answer"]["status"] == first[rid] and e.attempts == 1
        assert json.loads(e.data["server_answer"]["body"]) == {"error": f"said {first[rid]}"}
        assert e.last_error.startswith(f"HTTP {first[rid]}")
        assert not (box.locks_dir / f"{rid}.lock").exists()
    for rid, e in waiting.items():
        if rid in want["not_tried"]:
            assert e.attempts == 0 and e.last_error is None
        else:
            assert e.attempts == 1 and e.last_error != IN_FLIGHT
            assert (str(first[rid]) in e.last_error) if first[rid] != "reset" else "connection" in e.last_error
    for rid in want["delivered"]:
        assert not (box.locks_dir / f"{rid}.lock").exists()

    # flushes until nothing waits: every result that was not refused arrives, each stored once, in order
    for _ in range(12):
        if box.flush(HttpSender(), stop_on_transient=not keep_going).clean:
            break
    refused = {rid for rid, _, a in order if a in REFUSE}  # only a first answer refuses (later ones may pass)
    for n, s in enumerate(servers):
        mine = [rid for _, rid, srv, _ in sorted(made) if srv == n and rid not in refused]
        assert sorted(s.stored) == sorted(mine)
        assert all(c == 1 for c in s.store_count.values())
        assert not any(r.after_ack for r in s.requests)  # nothing sent again once a 2xx arrived
        assert all(r.json() == bodies[r.key] for r in s.requests)  # what was put is what arrived
    assert box.entries() == [] and sorted(e.run_id for e in box.failed()) == sorted(refused)


class Killed(BaseException):
    """Stands for the process dying: nothing after it runs."""


@SETTINGS
@given(kill=st.sampled_from(["before_send", "after_answer"]), runs=st.integers(1, 3), resends=st.integers(1, 3))
def test_a_sender_killed_at_any_point_leaves_the_entry_and_the_resend_carries_the_same_key(
        servers: list[CourseServer], folders: Any, kill: str, runs: int,
        resends: int) -> None:
    server = servers[0]
    keyed_server(server, {})
    box = Outbox(folders())
    payloads = [make_payload(next(IDS), blue_sorted=i) for i in range(runs)]
    for p in payloads:
        box.put(p, server.url, OPTS)
    real = HttpSender()

    def dying(entry: Any) -> SendResult:
        if kill == "after_answer":
            real(entry)  # the server stored and answered 2xx; the sender dies before deleting the entry
        raise Killed

    for _ in range(resends):  # killed again and again on the first entry it takes
        with pytest.raises(Killed):
            box.flush(dying)
    assert len(box.entries()) == runs  # nothing lost
    killed = [e for e in box.entries() if e.attempts]
    assert len(killed) == 1 and killed[0].attempts == resends and killed[0].last_error == IN_FLIGHT
    report = box.flush(HttpSender())
    assert sorted(report.delivered) == sorted(p["run_id"] for p in payloads) and box.entries() == []
    assert sorted(server.stored) == sorted(p["run_id"] for p in payloads)
    assert all(c == 1 for c in server.store_count.values())
    assert {k: server.stored[k] for k in server.stored} == {p["run_id"]: p for p in payloads}
    sent = server.keys()
    want_sends = len(payloads) + (resends if kill == "after_answer" else 0)
    assert len(sent) == want_sends and set(sent) == {p["run_id"] for p in payloads}
