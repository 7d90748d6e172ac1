"""The student's path in one command: ``robokit run CONFIG --report-url URL`` sends ``$ROBOKIT_TOKEN``; a refused
report is one loud line saying what to change, exit 5, the result kept; ``robokit outbox retry`` sends it again;
``robokit outbox list`` says each entry's state, whose it is and why. Against a real HTTP server on 127.0.0.1
(tests/report_server.py) answering the way the course server does (``{"error": ..., "field": ...}``)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from report_server import Answer, CourseServer

from robokit.cli import main
from robokit.report.outbox import Outbox

ROOT = Path(__file__).resolve().parents[1]
DROP_TEST = ROOT / "configs" / "drop_test.toml"
NO_TOKEN_401 = Answer(401, json.dumps({"error": "no token sent: this class needs a student's token",
                                       "field": "Authorization"}), headers=(("WWW-Authenticate", "Bearer"),),
                      store=False)


@pytest.fixture
def server() -> Iterator[CourseServer]:
    srv = CourseServer().start()
    yield srv
    srv.stop()


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    for name in ("ROBOKIT_TOKEN", "OTHER_TOKEN"):
        monkeypatch.delenv(name, raising=False)
    return tmp_path


def _run(url: str, *extra: str) -> int:
    """The drop test, its behaviour cut to 0.5 sim-s (it then succeeds) by ``--set``, reported to ``url``."""
    return main(["run", str(DROP_TEST), "--report-url", url, "--student", "kim", "--project", "A",
                 "--set", "behaviour.duration=0.5", *extra])


def _auth(server: CourseServer) -> list[str | None]:
    return [r.headers.get("authorization") for r in server.requests]


def test_the_token_in_robokit_token_is_sent_without_any_config(server, here, monkeypatch) -> None:
    monkeypatch.setenv("ROBOKIT_TOKEN", "rks_student-kim-0001")
    assert _run(server.url) == 0
    assert _auth(server) == ["Bearer rks_student-kim-0001"]


def test_token_env_picks_another_variable(server, here, monkeypatch) -> None:
    monkeypatch.setenv("ROBOKIT_TOKEN", "rks_not-this-one")
    monkeypatch.setenv("OTHER_TOKEN", "rks_this-one")
    assert _run(server.url, "--token-env", "OTHER_TOKEN") == 0
    assert _auth(server) == ["Bearer rks_this-one"]


def test_no_token_anywhere_sends_none(server, here) -> None:
    assert _run(server.url) == 0
    assert _auth(server) == [None]


def test_run_set_overrides_a_config_key_with_sweeps_syntax(server, here) -> None:
    assert _run(server.url, "--set", "world.seed=7", "--set", "world.max_time=0.25") == 1  # before 0.5: aborted
    body = server.requests[0].json()
    assert body["seed"] == 7 and body["outcome"] == "aborted" and abs(body["sim_time"] - 0.25) < 0.01


def test_run_set_with_several_values_is_a_usage_error(here, capsys) -> None:
    assert main(["run", str(DROP_TEST), "--set", "world.seed=1,2"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "one value per key" in err and "robokit sweep" in err
    assert not (here / "results").exists()  # nothing ran


def test_a_401_is_one_loud_line_exit_5_result_kept_and_retry_delivers_it(server, here, monkeypatch, capsys) -> None:
    server.script(NO_TOKEN_401)
    assert _run(server.url) == 5
    err = capsys.readouterr().err
    [line] = [x for x in err.splitlines() if "refused" in x]
    assert line.startswith("robokit: error: report[http] refused (HTTP 401): no token sent: export ROBOKIT_TOKEN=... "
                           "(the token your teacher gave you), then `robokit outbox retry ")
    assert "the result is kept (outbox/failed/" in line
    [rid] = [p.name for p in (here / "results").iterdir()]
    assert json.loads((here / "results" / rid / "result.json").read_text())["run_id"] == rid  # the result is kept
    [refused] = Outbox(here / "outbox").failed()
    assert refused.run_id == rid and refused.identity == "no token"

    assert main(["outbox", "list"]) == 0
    listing = capsys.readouterr().out
    row = next(x for x in listing.splitlines() if x.startswith(rid))
    assert row.split()[1:3] == ["refused", "yours"] and "HTTP 401" in row and "export ROBOKIT_TOKEN" in row

    monkeypatch.setenv("ROBOKIT_TOKEN", "rks_student-kim-0001")
    assert main(["outbox", "retry"]) == 0
    assert _auth(server) == [None, "Bearer rks_student-kim-0001"]
    assert server.keys() == [rid, rid] and server.store_count == {rid: 1}
    assert Outbox(here / "outbox").failed() == [] and Outbox(here / "outbox").entries() == []


def test_a_400_names_the_field_and_retry_can_change_it(server, here, capsys) -> None:
    server.script(Answer(400, json.dumps({"error": "project: missing", "field": "project"}), store=False))
    assert _run(server.url) == 5
    line = next(x for x in capsys.readouterr().err.splitlines() if "refused" in x)
    assert "project: missing" in line and "--project NAME" in line
    [refused] = Outbox(here / "outbox").failed()
    assert main(["outbox", "retry", refused.run_id[:8], "--project", "B"]) == 0
    assert [r.json()["project"] for r in server.requests] == ["A", "B"]


def test_a_failed_run_whose_report_is_refused_still_exits_5(server, here, capsys) -> None:
    server.script(Answer(403, json.dumps({"error": "this class is closed", "field": None}), store=False))
    assert _run(server.url, "--max-time", "0.2") == 5  # the run itself was aborted (exit 1): the refusal wins
    line = next(x for x in capsys.readouterr().err.splitlines() if "refused" in x)
    assert "(HTTP 403): the server said: this class is closed" in line


def test_retry_leaves_an_entry_made_under_another_token_unless_claimed(server, here, monkeypatch, capsys) -> None:
    monkeypatch.setenv("ROBOKIT_TOKEN", "rks_revoked-kim")
    server.script(Answer(401, json.dumps({"error": "revoked token", "field": "Authorization"}), store=False))
    assert _run(server.url) == 5
    assert "did not accept the token in $ROBOKIT_TOKEN" in capsys.readouterr().err
    [refused] = Outbox(here / "outbox").failed()
    assert refused.identity == "sha256:" + hashlib.sha256(b"rks_revoked-kim").hexdigest()[:12]
    assert "rks_revoked-kim" not in refused.path.read_text()  # the fingerprint, never the token
    monkeypatch.setenv("ROBOKIT_TOKEN", "rks_new-kim")
    assert main(["outbox", "retry"]) == 1
    assert "not yours" in capsys.readouterr().out and len(server.requests) == 1
    assert main(["outbox", "retry", "--claim"]) == 0
    assert _auth(server)[-1] == "Bearer rks_new-kim"


def test_a_400_for_a_missing_student_without_a_token_names_the_token(server, here, capsys) -> None:
    """A server that answers a token-less post with 400 ``student: missing``: the line still says what is wrong."""
    server.script(Answer(400, json.dumps({"error": "student: missing", "field": "student"}), store=False))
    assert main(["run", str(DROP_TEST), "--report-url", server.url, "--project", "A", "--set",
                 "behaviour.duration=0.5"]) == 5
    line = next(x for x in capsys.readouterr().err.splitlines() if "refused" in x)
    assert "student: missing: no token sent: export ROBOKIT_TOKEN=..." in line and "--student NAME" in line
