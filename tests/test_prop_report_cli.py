"""``robokit outbox list | flush | retry`` as properties over generated outboxes, judged by the files read back, a
real loopback server's record, and the listing worked out plainly here from docs/reporting.md.

* ``list`` shows every entry, waiting ones then refused ones, each oldest first, with its state, whose it is
  ("yours" under your token's fingerprint), its age (``42s``, ``3m07s``, ``5h02m``, ``2d03h``), attempts and why
  (the last error, then `` - `` and the advice of a refused one); then one count line; ``--failed`` only the refused;
  ``--json`` all of it; exit 0.
* ``flush`` sends yours only, exits 0 iff every entry it took was delivered (others' entries do not count).
* ``retry`` puts refused entries made without a token or under yours back (``--claim``: others' too), with
  ``--project`` / ``--student`` applied to what the server receives, and exits 0 iff all it took arrived.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
import time
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer, make_payload
from robokit_plugins.http_report import HttpOptions

from robokit.cli import main
from robokit.report.outbox import NO_TOKEN, Outbox
from robokit.report.reporting import write_json_atomic

pytest_plugins = ["report_props"]

OPTS = HttpOptions(retries=0, backoff_factor=0.0, backoff_jitter=0.0).to_dict()
TOKENS = ("rks_me-0001", "rks_other-0002")
SETTINGS = settings(max_examples=6, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def fp(token: str | None) -> str:
    """The docs' rule: ``sha256:`` + the first 12 hex digits of the token's SHA-256, or ``no token``."""
    return "sha256:" + hashlib.sha256(token.encode()).hexdigest()[:12] if token else "no token"


def age(s: int) -> str:
    """The docs' age column, written out plainly."""
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    if s < 86400:
        return f"{s // 3600}h{(s % 3600) // 60:02d}m"
    return f"{s // 86400}d{(s % 86400) // 3600:02d}h"

IDS = itertools.count(1)
"""Run ids never reused between examples (a server thread may still be settling the last one's request)."""


def reset(server: CourseServer, plan: Any = None) -> None:
    server.requests.clear()
    server.stored.clear()
    server.store_count.clear()
    server.acked.clear()
    server.plan = plan or (lambda n: Answer())


entries = st.lists(st.fixed_dictionaries({
    "refused": st.booleans(),
    "whose": st.sampled_from([None, *TOKENS]),
    "age": st.one_of(st.integers(0, 59), st.integers(60, 3599), st.integers(3600, 86399),
                     st.integers(86400, 9 * 86400)),
    "attempts": st.integers(0, 12),
    "error": st.sampled_from(["HTTP 503 after retries: busy", "connection failed: [Errno 111] refused", None]),
    "advice": st.sampled_from([None, "give --project NAME"]),
}), min_size=0, max_size=5)


def make_box(box: Outbox, url: str, specs: list[dict[str, Any]]) -> list[tuple[str, dict[str, Any]]]:
    now = time.time()
    made = []
    for spec in specs:
        entry = box.put(make_payload(next(IDS)), url, OPTS, identity=fp(spec["whose"]))
        data = {**entry.data, "created_at": now - spec["age"] - 0.5, "attempts": spec["attempts"],
                "last_error": spec["error"]}
        path = entry.path
        if spec["refused"]:
            data["advice"] = spec["advice"]
            data["server_answer"] = {"status": 422, "body": "{}", "at": "2026-01-01T00:00:00+00:00"}
            path.unlink()
            path = box.failed_dir / path.name
        write_json_atomic(path, data, overwrite=True)
        made.append((entry.run_id, spec))
    return made


@SETTINGS
@given(specs=entries, me=st.sampled_from([None, *TOKENS]), only_failed=st.booleans())
def test_list_shows_every_entry_with_its_state_owner_age_attempts_and_why(
        folders: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], specs: list[Any],
        me: str | None, only_failed: bool) -> None:
    box = Outbox(folders())
    made = make_box(box, "http://127.0.0.1:9/api/robotics/result/", specs)
    if me is None:
        monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    else:
        monkeypatch.setenv("ROBOKIT_TOKEN", me)
    capsys.readouterr()
    assert main(["outbox", "list", "--dir", str(box.root)] + (["--failed"] if only_failed else [])) == 0
    lines = capsys.readouterr().out.splitlines()

    def oldest_first(rows: list[tuple[str, dict[str, Any]]]) -> list[tuple[str, dict[str, Any]]]:
        return sorted(rows, key=lambda r: (-r[1]["age"], r[0]))

    waiting = oldest_first([r for r in made if not r[1]["refused"]])
    refused = oldest_first([r for r in made if r[1]["refused"]])
    shown = ([] if only_failed else [(r, "waiting") for r in waiting]) + [(r, "refused") for r in refused]
    row_re = re.compile(r"^(\S+) +(waiting|refused) +(.+?) +(\S+) +(\d+)  (.*)$")  # WHOSE may be "no token"
    rows = [list(m.groups()) for m in map(row_re.match, lines) if m]
    assert [(row[0], row[1]) for row in rows] == [(rid, state) for (rid, _), state in shown]
    for row, ((_, spec), state) in zip(rows, shown, strict=True):
        whose = "yours" if fp(spec["whose"]) == fp(me) else fp(spec["whose"])
        why = (spec["error"] or "-") + (f" - {spec['advice']}" if state == "refused" and spec["advice"] else "")
        assert row[2:] == [whose, age(spec["age"]), str(spec["attempts"]), why]
    if shown:
        assert lines[0].split() == ["RUN", "ID", "STATE", "WHOSE", "AGE", "ATTEMPTS", "WHY"]
    else:
        assert not any(line.startswith("RUN ID") for line in lines)
    count = next(line for line in lines if "waiting in" in line)
    assert count.startswith(f"{len(waiting)} waiting in {box.root}; {len(refused)} refused in {box.failed_dir} "
                            f"(you: {fp(me)})")

    assert main(["outbox", "list", "--dir", str(box.root), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["you"] == fp(me) and data["dir"] == str(box.root) and data["unreadable"] == []
    for key, want, state in (("waiting", waiting, "waiting"), ("failed", refused, "refused")):
        assert [(r["run_id"], r["state"], r["identity"], r["attempts"], r["last_error"]) for r in data[key]] == [
            (rid, state, fp(spec["whose"]), spec["attempts"], spec["error"]) for rid, spec in want]
        for r, (_, spec) in zip(data[key], want, strict=True):
            assert spec["age"] + 0.4 <= r["age_s"] <= spec["age"] + 30
            assert r["advice"] == (spec["advice"] if state == "refused" else None)
            assert "payload" not in r


@SETTINGS
@given(specs=st.lists(st.tuples(st.sampled_from([None, *TOKENS]), st.sampled_from([201, 422, 503])),
                      min_size=0, max_size=4),
       me=st.sampled_from([None, *TOKENS]), keep_going=st.booleans())
def test_flush_sends_only_yours_and_exits_0_iff_all_it_took_arrived(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        specs: list[Any], me: str | None, keep_going: bool) -> None:
    box = Outbox(folders())
    answers: dict[str, int] = {}
    mine: list[str] = []
    for i, (whose, status) in enumerate(specs):
        entry = box.put(make_payload(next(IDS)), server.url, OPTS, identity=fp(whose))
        write_json_atomic(entry.path, {**entry.data, "created_at": 1_700_000_000.0 + i}, overwrite=True)
        answers[entry.run_id] = status
        if fp(whose) == fp(me):
            mine.append(entry.run_id)
    reset(server)
    server._record = _keyed_record(server, answers)  # type: ignore[method-assign]
    if me is None:
        monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    else:
        monkeypatch.setenv("ROBOKIT_TOKEN", me)
    capsys.readouterr()
    code = main(["outbox", "flush", "--dir", str(box.root)] + (["--keep-going"] if keep_going else []))
    out = capsys.readouterr().out
    # the plain walk: mine oldest first; after a 503 the later ones wait unless --keep-going
    tried, delivered, refused, waiting = [], [], [], []
    for rid in mine:
        if waiting and not keep_going:
            continue
        tried.append(rid)
        {201: delivered, 422: refused, 503: waiting}[answers[rid]].append(rid)
    assert server.keys() == tried
    assert all(r.headers.get("authorization") == (f"Bearer {me}" if me else None) for r in server.requests)
    assert code == (0 if len(delivered) == len(mine) else 1)
    left = len(mine) - len(delivered) - len(refused)
    assert f"{len(delivered)} delivered, {len(refused)} refused (moved to failed/), {left} still waiting" in out
    others: dict[str, int] = {}
    for whose, _ in specs:
        if fp(whose) != fp(me):
            others[fp(whose)] = others.get(fp(whose), 0) + 1
    assert ("left waiting, not yours" in out) == bool(others)
    for who, n in others.items():  # whose, and how many, each in the one line
        assert f"{n} made " + ("without a token" if who == NO_TOKEN else f"under token {who}") in out
    assert sorted(e.run_id for e in box.entries()) == sorted(set(answers) - set(delivered) - set(refused))


def _keyed_record(server: CourseServer, answers: dict[str, int]) -> Any:
    """Answer each request by its key's status (the plan sees the request, not only its number)."""
    original = CourseServer._record

    def record(path: str, headers: dict[str, str], body: bytes, clock: float) -> Any:
        status = answers.get(headers.get("idempotency-key") or "", 201)
        server.plan = lambda _n: Answer(status, json.dumps({"error": "no"}), store=status == 201)
        return original(server, path, headers, body, clock)

    return record


@SETTINGS
@example(specs=[None, TOKENS[0]], me=TOKENS[0], claim=False, name=False, project="B", student="lee", down=False)
@example(specs=[TOKENS[1], None], me=TOKENS[0], claim=False, name=True, project="B", student=None, down=True)
@example(specs=[TOKENS[1], TOKENS[0]], me=TOKENS[0], claim=True, name=False, project=None, student="lee", down=True)
@example(specs=[TOKENS[1], TOKENS[0]], me=TOKENS[0], claim=False, name=False, project=None, student=None, down=False)
@given(specs=st.lists(st.sampled_from([None, *TOKENS]), min_size=1, max_size=4),
       me=st.sampled_from(TOKENS), claim=st.booleans(), name=st.booleans(),
       project=st.sampled_from([None, "B"]), student=st.sampled_from([None, "lee"]), down=st.booleans())
def test_retry_takes_refused_entries_that_are_yours_and_sends_them_as_changed(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        specs: list[Any], me: str, claim: bool, name: bool, project: str | None, student: str | None,
        down: bool) -> None:
    box = Outbox(folders())
    made = []
    for i, whose in enumerate(specs):
        entry = box.put(make_payload(next(IDS)), server.url, OPTS, identity=fp(whose))
        data = {**entry.data, "created_at": 1_700_000_000.0 + i, "last_error": "HTTP 400: project",
                "advice": "give --project", "server_answer": {"status": 400, "body": "{}", "at": "x"}}
        entry.path.unlink()
        write_json_atomic(box.failed_dir / entry.path.name, data, overwrite=True)
        made.append((entry.run_id, whose))
    reset(server, (lambda n: Answer(503, "busy", store=False)) if down else None)
    monkeypatch.setenv("ROBOKIT_TOKEN", me)
    named = made[-1:] if name else made
    args = ["outbox", "retry", "--dir", str(box.root)] + ([made[-1][0]] if name else [])
    args += (["--claim"] if claim else []) + (["--project", project] if project else [])
    args += ["--student", student] if student else []
    capsys.readouterr()
    code = main(args)
    out = capsys.readouterr().out
    taken = [rid for rid, whose in named if claim or fp(whose) in (fp(me), NO_TOKEN)]
    assert server.keys() == taken
    for rec in server.requests:
        body = rec.json()
        i = int(body["run_id"][-12:])
        want = make_payload(i)
        want.update({k: v for k, v in (("project", project), ("student", student)) if v})
        assert body == want and rec.headers["authorization"] == f"Bearer {me}"
    assert code == (0 if len(taken) == len(named) and not down else 1)  # a refused entry left as it is counts
    left = {rid for rid, _ in made} - set(taken)
    assert {e.run_id for e in box.failed()} == left
    # a retry the server did not answer waits in the outbox, now yours, as changed, without the old refusal
    assert sorted(e.run_id for e in box.entries()) == (sorted(taken) if down else [])
    for e in box.entries():
        assert e.identity == fp(me) and e.attempts == 1 and "server_answer" not in e.data and "advice" not in e.data
        assert e.payload == {**make_payload(int(e.run_id[-12:])),
                             **{k: v for k, v in (("project", project), ("student", student)) if v}}
        assert e.last_error.startswith("HTTP 503")
    for rid, whose in named:
        if rid not in taken:
            assert f"{rid}: made under token {fp(whose)}, not yours ({fp(me)})" in out


def test_retry_with_nothing_refused_says_so_and_exits_0(folders: Any, capsys: pytest.CaptureFixture[str]) -> None:
    box = Outbox(folders())
    capsys.readouterr()
    assert main(["outbox", "retry", "--dir", str(box.root)]) == 0
    assert capsys.readouterr().out == f"nothing to retry: no refused entry in {box.failed_dir}\n"


def test_retry_sends_the_refused_entries_only_never_the_waiting_ones(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    reset(server)
    box = Outbox(folders())
    waiting = box.put(make_payload(next(IDS)), server.url, OPTS, identity=fp(TOKENS[0]))
    refused = box.put(make_payload(next(IDS)), server.url, OPTS, identity=fp(TOKENS[0]))
    refused.path.unlink()
    write_json_atomic(box.failed_dir / refused.path.name, {**refused.data, "last_error": "HTTP 400"}, overwrite=True)
    monkeypatch.setenv("ROBOKIT_TOKEN", TOKENS[0])
    assert main(["outbox", "retry", "--dir", str(box.root)]) == 0
    assert server.keys() == [refused.run_id]  # a waiting entry waits for `flush`, in its order
    assert [e.run_id for e in box.entries()] == [waiting.run_id] and box.failed() == []
