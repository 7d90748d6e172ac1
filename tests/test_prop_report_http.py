"""The ``http`` reporter's promises as properties, judged at a real loopback server that records what arrives.

docs/reporting.md: the body is the payload as compact UTF-8 JSON; the headers are ``Content-Type:
application/json``, ``Idempotency-Key: <run_id>``, ``User-Agent: robokit/<version>`` and ``Authorization: Bearer
<token>`` only when a token is set; 5xx, 408, 429 and dropped connections are tried ``retries + 1`` times with the
same key, then the result waits in the outbox; a 3xx waits too, naming where it redirects; any other 4xx moves it to
``failed/`` with the server's answer and one line of advice that names the field the server named and ends with how
to send it again; a token the server echoes is ``***`` everywhere it is kept or shown; a payload over
``max_payload_bytes`` is never sent; a URL that can never be posted to is never tried.
"""

from __future__ import annotations

import itertools
import json
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer, make_payload
from robokit_plugins.http_report import HttpReportConfig, HttpReporter, encode, url_problem

from robokit import __version__
from robokit.report.outbox import Outbox
from robokit.report.reporting import Refused

pytest_plugins = ["report_props"]

SETTINGS = settings(max_examples=8, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
IDS = itertools.count(1)
TOKEN = "rks_s3cret-f00d-0042"
TRANSIENT = [500, 502, 503, 504, 408, 429, "reset"]


def reset(server: CourseServer) -> None:
    server.requests.clear()
    server.stored.clear()
    server.store_count.clear()
    server.acked.clear()


def answer(kind: Any, body: str = "") -> Answer:
    if kind == "reset":
        return Answer(reset=True, store=False)
    return Answer(kind, body or json.dumps({"error": f"said {kind}"}), store=200 <= kind < 300)


results = st.dictionaries(st.sampled_from(["red_sorted", "blue_sorted", "failures", "total_time", "note", "이름"]),
                          st.one_of(st.integers(-5, 10**6), st.floats(-1e6, 1e6, allow_nan=False),
                                    st.text(max_size=8)), max_size=4)


@settings(SETTINGS, max_examples=4)
@example(result={}, transient=[], retries=0, end=401, token=None, field=None)
@example(result={}, transient=[], retries=0, end=401, token="own", field="Authorization")
@example(result={"red_sorted": 2}, transient=[], retries=0, end=400, token="env", field="project")
@example(result={}, transient=[429], retries=1, end=422, token=None, field="world.max_time")
@example(result={}, transient=[], retries=0, end=422, token="env", field="student")
@example(result={}, transient=[], retries=0, end=409, token="own", field=None)
@example(result={}, transient=["reset"], retries=0, end=201, token=None, field=None)
@example(result={}, transient=[503], retries=0, end=201, token="env", field=None)
@given(result=results, transient=st.lists(st.sampled_from(TRANSIENT), max_size=3), retries=st.integers(0, 2),
       end=st.sampled_from([200, 201, 202, 400, 401, 404, 422, 301, 307]), token=st.sampled_from([None, "env", "own"]),
       field=st.sampled_from([None, "project", "student", "world.max_time", "text"]))
def test_what_arrives_and_where_the_result_ends(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch, result: dict[str, Any],
        transient: list[Any], retries: int, end: int, token: str | None, field: str | None) -> None:
    reset(server)
    echo = f"you sent Bearer {TOKEN}" if token else "no"
    headers = (("Location", "https://elsewhere.example/api/"),) if 300 <= end < 400 else ()
    body = json.dumps({"error": f"said  {end}:\n {echo}", "field": field}) if end >= 400 else "{}"
    if field == "text":  # not the course server's JSON: its text is the message
        body = f"said  {end}:\n {echo} " + "x" * 300
    server.script(*[answer(k) for k in transient], then=Answer(end, body, headers=headers, store=end < 300))
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    monkeypatch.delenv("MY_TOKEN", raising=False)
    if token == "env":
        monkeypatch.setenv("ROBOKIT_TOKEN", TOKEN)
    elif token == "own":
        monkeypatch.setenv("MY_TOKEN", TOKEN)
    box = folders() / "outbox"
    cfg = HttpReportConfig(url=server.url, outbox=str(box), retries=retries, backoff_factor=0.0,
                           backoff_jitter=0.0, flush_outbox=False, token_env="MY_TOKEN" if token == "own" else None)
    payload = make_payload(next(IDS), **result)
    delivery = HttpReporter("http", cfg).report(payload)

    tries = min(len(transient) + 1, retries + 1)
    assert len(server.requests) == tries
    for rec in server.requests:
        assert rec.body == json.dumps(payload, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
        assert rec.key == payload["run_id"] and rec.path == "/api/robotics/result/"
        assert rec.headers["content-type"] == "application/json"
        assert rec.headers["user-agent"] == f"robokit/{__version__}"
        assert rec.headers.get("authorization") == (f"Bearer {TOKEN}" if token else None)
    outbox = Outbox(box)
    reached = tries > len(transient)  # the server's own answer (not a scripted failure) was the last
    kept = outbox.entries() + outbox.failed()
    shown = delivery.message + "".join(json.dumps(e.data) for e in kept)
    assert TOKEN not in shown  # an echoed token is *** wherever it is kept or shown
    if reached and 200 <= end < 300:
        assert delivery.delivered and kept == [] and server.stored == {payload["run_id"]: payload}
        assert f"HTTP {end}" in delivery.message
        return
    assert not delivery.delivered
    [entry] = kept
    assert entry.payload == payload and entry.attempts == 1 and delivery.stored == str(entry.path)
    if reached and end >= 400:
        assert isinstance(delivery, Refused) and delivery.status == end and entry in outbox.failed()
        assert entry.data["server_answer"]["status"] == end
        assert ("***" in entry.data["server_answer"]["body"]) == bool(token)
        advice = entry.data["advice"]
        assert advice == delivery.advice and "\n" not in advice
        assert f"robokit outbox retry {payload['run_id']}" in advice
        said = f"said {end}: {echo}"  # whitespace folded
        if field == "text":  # and its start only
            said = (said + " " + "x" * 300)[:200]
        said = said.replace(TOKEN, "***")  # the token blanked
        rid = payload["run_id"]
        if end == 401 and not token:
            assert "export ROBOKIT_TOKEN=" in advice
        elif field == "student" and not token:  # a class that wants tokens, or a name left out: both said
            assert said in advice and "export ROBOKIT_TOKEN=" in advice and f"{rid} --student NAME" in advice
        elif end == 401:  # the token was sent and not accepted: the advice is about the token, by its variable
            assert ("$MY_TOKEN" if token == "own" else "$ROBOKIT_TOKEN") in advice and said in advice
        elif field in ("project", "student"):
            assert advice == (f"{field}: {said}: give --{field} NAME (or [report] {field} = \"NAME\"); this "
                              f"result: `robokit outbox retry {rid} --{field} NAME`")
        elif field == "world.max_time":
            assert advice.startswith(f"{field}: {said}: change it in the config")
        else:
            assert advice.startswith(f"the server said: {said}; ")
        assert delivery.line().startswith(f"refused (HTTP {end}): {advice}; the result is kept ({entry.path})")
        return
    assert entry in outbox.entries() and not isinstance(delivery, Refused)
    assert f"outbox {entry.path}" in delivery.message
    if reached:
        assert f"HTTP {end}" in entry.last_error and "elsewhere.example" in entry.last_error
    elif transient[tries - 1] == "reset":
        assert entry.last_error.startswith("connection failed") and f"after {retries} retries" in entry.last_error
    else:
        assert entry.last_error.startswith(f"HTTP {transient[tries - 1]} after retries")


@SETTINGS
@given(pad=st.integers(0, 300), slack=st.integers(-3, 3))
def test_a_payload_over_the_limit_is_never_sent_and_one_at_the_limit_is(
        server: CourseServer, folders: Any, pad: int, slack: int) -> None:
    reset(server)
    payload = make_payload(next(IDS), note="한" * pad)
    size = len(encode(payload))
    assert size == len(json.dumps(payload, separators=(",", ":"), ensure_ascii=False).encode("utf-8"))
    box = folders() / "outbox"
    cfg = HttpReportConfig(url=server.url, outbox=str(box), retries=0, max_payload_bytes=size + slack,
                           flush_outbox=False)
    delivery = HttpReporter("http", cfg).report(payload)
    if slack >= 0:
        assert delivery.delivered and server.keys() == [payload["run_id"]]
    else:
        assert not delivery.delivered and server.requests == []
        [entry] = Outbox(box).failed()
        assert f"payload is {size} bytes, over the {size + slack}-byte limit" in entry.last_error


@SETTINGS
@given(bad=st.sampled_from([" ", "\t", "\x7f", "\x00"]), where=st.integers(0, 30))
def test_a_url_with_a_space_or_control_character_is_never_tried(bad: str, where: int) -> None:
    url = "http://127.0.0.1:8000/api/robotics/result/"
    broken = url[:where] + bad + url[where:]
    assert url_problem(url) is None
    assert url_problem(broken) is not None
    with pytest.raises(ValueError):
        HttpReportConfig(url=broken)


def test_a_stopped_run_keeps_its_result_in_the_outbox_without_sending(server: CourseServer, folders: Any,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.report.reporting import deliver

    reset(server)
    monkeypatch.setenv("ROBOKIT_TOKEN", TOKEN)
    box = folders() / "outbox"
    payload = make_payload(next(IDS))
    stop = type("Stop", (), {"signalled": True, "installed": True})()
    [(name, delivery)] = deliver([HttpReporter("http", HttpReportConfig(url=server.url, outbox=str(box)))],
                                 payload, stop=stop)
    assert name == "http" and delivery.delivered is False and server.requests == []
    [entry] = Outbox(box).entries()
    assert entry.payload == payload and entry.attempts == 0 and delivery.stored == str(entry.path)
    assert entry.url == server.url and entry.options["retries"] == 4  # sent later as this run's config says
    assert delivery.message == (f"not sent (interrupted); result kept in the outbox {entry.path} - "
                                f"`robokit outbox flush --dir {box}` sends it")
    assert "interrupted" in entry.last_error and TOKEN not in json.dumps(entry.data)
    assert entry.identity.startswith("sha256:")


@pytest.mark.slow  # each unanswered try waits out a read timeout
@settings(SETTINGS, max_examples=5)
@given(stalls=st.integers(1, 3), retries=st.integers(0, 2))
def test_a_slow_server_that_stored_the_result_is_sent_the_same_key_until_it_answers(
        server: CourseServer, folders: Any, stalls: int, retries: int) -> None:
    from robokit_plugins.http_report import HttpSender

    reset(server)
    server.script(*[Answer(stall=True)] * stalls)  # stores the result, then never answers
    box = folders() / "outbox"
    cfg = HttpReportConfig(url=server.url, outbox=str(box), retries=retries, read_timeout=0.3, backoff_factor=0.0,
                           backoff_jitter=0.0, flush_outbox=False)
    payload = make_payload(next(IDS))
    delivery = HttpReporter("http", cfg).report(payload)
    assert delivery.delivered == (stalls <= retries)
    flushes = 0
    while Outbox(box).entries():
        [entry] = Outbox(box).entries()
        assert entry.last_error == f"no answer within the read timeout (0.3 s), after {retries} retries"
        Outbox(box).flush(HttpSender())
        flushes += 1
    assert flushes == stalls // (retries + 1) and Outbox(box).failed() == []
    assert server.keys() == [payload["run_id"]] * (stalls + 1)
    assert server.stored == {payload["run_id"]: payload} and server.store_count[payload["run_id"]] == 1


@SETTINGS
@given(waiting=st.lists(st.tuples(st.sampled_from(["same", "other_url"]), st.sampled_from([None, TOKEN, "rks_x"])),
                        max_size=4),
       own=st.sampled_from([201, 503]), flush=st.booleans(), upload=st.booleans(), me=st.sampled_from([None, TOKEN]))
def test_a_run_that_delivers_then_sends_what_waits_for_the_same_server_and_owner(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch, waiting: list[Any], own: int,
        flush: bool, upload: bool, me: str | None) -> None:
    """docs/reporting.md: after this run's result is delivered, what waits in the outbox for the same URL and the same
    identity is sent (``flush_outbox``); entries for other URLs or other tokens are left alone; with
    ``upload_artifacts`` the run folder's files follow the result to ``<url><run_id>/artifacts/``; nothing of
    this changes the run's own report."""
    from robokit_plugins.http_report import HttpOptions

    from robokit.report.outbox import fingerprint

    reset(server)
    root = folders()
    box = Outbox(root / "outbox")
    other_url = server.url.replace("/result/", "/elsewhere/")
    older: list[tuple[str, str, str | None]] = []
    for where, whose in waiting:
        entry = box.put(make_payload(next(IDS)), server.url if where == "same" else other_url,
                        HttpOptions(retries=0).to_dict(), identity=fingerprint(whose))
        older.append((entry.run_id, where, whose))
    payload = make_payload(next(IDS))
    if upload:
        (root / "results" / payload["run_id"]).mkdir(parents=True)
        (root / "results" / payload["run_id"] / "plot.png").write_bytes(b"png")
    server.script(Answer(own, "{}", store=own == 201))
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    if me:
        monkeypatch.setenv("ROBOKIT_TOKEN", me)
    cfg = HttpReportConfig(url=server.url, outbox=str(box.root), retries=0, flush_outbox=flush,
                           upload_artifacts=upload, artifacts_dir=str(root / "results"))
    delivery = HttpReporter("http", cfg).report(payload)
    sent = [rid for rid, where, whose in older if where == "same" and fingerprint(whose) == fingerprint(me)]
    results = [r for r in server.requests if not r.path.endswith("/artifacts/")]
    uploads = [r for r in server.requests if r.path.endswith("/artifacts/")]
    if own != 201:
        assert not delivery.delivered and [r.key for r in results] == [payload["run_id"]] and uploads == []
        assert len(box.entries()) == len(older) + 1
        return
    assert delivery.delivered and delivery.message.startswith(f"delivered to {server.url} (HTTP 201)")
    assert [r.key for r in results] == [payload["run_id"]] + (sent if flush else [])
    assert all(r.headers.get("authorization") == (f"Bearer {me}" if me else None) for r in server.requests)
    assert [r.path for r in uploads] == ([f"/api/robotics/result/{payload['run_id']}/artifacts/"] if upload else [])
    assert ("artifacts: 1/1 uploaded" in delivery.message) == upload
    left = {e.run_id for e in box.entries()}
    assert left == {rid for rid, _, _ in older} - (set(sent) if flush else set())
    if flush and any(where == "same" for _, where, _ in older):
        n = len(sent)
        assert delivery.message.endswith(f"; outbox {box.root}: {n} delivered, 0 refused (moved to failed/), "
                                         "0 still waiting, 0 busy in another flush")
    else:
        assert "outbox" not in delivery.message


@settings(SETTINGS, max_examples=6)
@given(end=st.sampled_from([201, 200, 503, 422, "reset"]))
def test_an_outbox_that_cannot_be_written_never_stops_a_delivery_and_says_both_when_it_fails(
        server: CourseServer, folders: Any, end: Any) -> None:
    reset(server)
    root = folders()
    (root / "blocker").write_text("a file where the outbox folder should be", encoding="utf-8")
    server.script(answer(end))
    payload = make_payload(next(IDS))
    cfg = HttpReportConfig(url=server.url, outbox=str(root / "blocker" / "outbox"), retries=0, flush_outbox=False)
    delivery = HttpReporter("http", cfg).report(payload)
    assert server.keys() == [payload["run_id"]]  # sent all the same, once
    assert delivery.stored is None and sorted(p.name for p in root.iterdir()) == ["blocker"]
    if end in (200, 201):
        assert delivery.delivered and delivery.message == f"delivered to {server.url} (HTTP {end})"
    else:
        assert not delivery.delivered
        assert delivery.message.startswith("not delivered (") and "could not be written" in delivery.message
        assert str(root / "blocker" / "outbox") in delivery.message


def test_ctrl_c_while_sending_keeps_the_result_in_the_outbox(server: CourseServer, folders: Any) -> None:
    """A real SIGINT reaches the run while its POST waits for the answer: the entry written before sending stays,
    says it was interrupted, and the next flush sends it with the same key."""
    import signal
    import threading

    from robokit_plugins.http_report import HttpSender

    reset(server)
    main_thread = threading.main_thread().ident
    assert main_thread is not None

    def interrupt(_rec: Any) -> None:
        signal.pthread_kill(main_thread, signal.SIGINT)

    def handler(_sig: int, _frame: Any) -> None:
        from robokit.errors import Interrupted

        raise Interrupted("SIGINT")

    server.on_request = interrupt
    server.script(Answer(stall=True))  # stores it, then never answers: the run is stopped while it waits
    box = folders() / "outbox"
    payload = make_payload(next(IDS))
    old = signal.signal(signal.SIGINT, handler)
    try:
        delivery = HttpReporter("http", HttpReportConfig(url=server.url, outbox=str(box), retries=0,
                                                         read_timeout=30.0, flush_outbox=False)).report(payload)
    finally:
        signal.signal(signal.SIGINT, old)
        server.on_request = None
    [entry] = Outbox(box).entries()
    assert not delivery.delivered and delivery.stored == str(entry.path)
    assert delivery.message.startswith("interrupted (SIGINT) while sending; result kept in the outbox")
    assert entry.attempts == 1 and entry.last_error.startswith("interrupted")
    assert Outbox(box).flush(HttpSender()).delivered == [payload["run_id"]]
    assert server.keys() == [payload["run_id"]] * 2 and server.store_count[payload["run_id"]] == 1


@settings(SETTINGS, max_examples=30)
@given(error=st.one_of(st.text(max_size=400), st.integers(), st.none()), field=st.one_of(st.text(max_size=8),
                                                                                          st.integers(), st.none()),
       as_json=st.booleans(), text=st.text(max_size=300))
def test_the_servers_answer_is_read_as_its_message_and_field(error: Any, field: Any, as_json: bool, text: str) -> None:
    """``{"error": ..., "field": ...}`` is the course server's answer: its message (blanks folded, at most 300
    characters) and its field when it names one; any other body is its own text, folded, at most 200 characters."""
    from robokit_plugins.http_report import server_error

    body = json.dumps({"error": error, "field": field}) if as_json else text
    message, named = server_error(body)
    if as_json and isinstance(error, str):
        folded = " ".join(error.split())
        assert message == folded[:300] and named == (field if isinstance(field, str) else None)
    else:
        folded = " ".join(body.split())
        assert message == folded[:200] and named is None
    assert "\n" not in message


def test_a_stopped_run_whose_outbox_cannot_be_written_says_so(server: CourseServer, folders: Any) -> None:
    reset(server)
    root = folders()
    (root / "blocker").write_text("a file where the outbox folder should be", encoding="utf-8")
    cfg = HttpReportConfig(url=server.url, outbox=str(root / "blocker" / "outbox"))
    delivery = HttpReporter("http", cfg).keep(make_payload(next(IDS)))
    assert delivery.delivered is False and delivery.stored is None and server.requests == []
    assert delivery.message.startswith(f"not sent (interrupted) and the outbox {root / 'blocker' / 'outbox'} could "
                                       "not be written: ")


def test_a_refusal_without_a_status_or_a_kept_copy_says_only_what_to_change() -> None:
    assert Refused(False, None, "m", why="w", advice="export X=...", status=None).line() == "refused: export X=..."
    kept = Refused(False, "f.json", "m", why="w", status=401)
    assert kept.line() == "refused (HTTP 401): w; the result is kept (f.json)"
