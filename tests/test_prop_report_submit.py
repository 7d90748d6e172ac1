"""``robokit submit`` against a server that refuses, drops connections, answers garbage or accepts, as properties
judged at a real loopback server (what arrived: path, headers, body) and by the lines and exit codes the module's
docs promise: exit 0 submitted, 2 refused (one ``robokit: error: <the file at fault>: <the server's error>`` line),
4 unreachable after every send, 5 still waiting, 1 not graded; one ``Idempotency-Key`` for every resend; the config
(and the plugin's ``*.py`` files, named under the package folder) sent as they are on disk; ``--wait`` prints each
official trial and the grade. The pauses between sends and polls are recorded, not slept.
"""

from __future__ import annotations

import argparse
import json
import types
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer

from robokit.errors import UserError
from robokit.report import submit

pytest_plugins = ["report_props"]

SETTINGS = settings(max_examples=6, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
NAMES = st.text(st.characters(min_codepoint=33, max_codepoint=0x24F, blacklist_characters="\\"), min_size=1,
                max_size=12)


def reset(server: CourseServer) -> None:
    server.requests.clear()
    server.stored.clear()
    server.store_count.clear()
    server.acked.clear()


ends = st.one_of(
    st.fixed_dictionaries({"kind": st.just("ok"), "status": st.sampled_from([200, 201]), "late": st.booleans(),
                           "plugins": st.lists(st.sampled_from(["mine", "helper"]), max_size=2, unique=True),
                           "seeds": st.integers(1, 30), "id": st.integers(1, 10_000)}),
    st.fixed_dictionaries({"kind": st.just("refused"), "status": st.sampled_from([400, 401, 403, 404, 409, 422]),
                           "field": st.sampled_from([None, "config", "plugin", "Authorization"]),
                           "error": st.sampled_from(["", "world.max_time: not yours to change"])}),
    st.fixed_dictionaries({"kind": st.just("garbage"), "status": st.sampled_from([500, 502, 503, 201])}),
)


@SETTINGS
@example(drops=1, end={"kind": "ok", "status": 201, "late": True, "plugins": ["mine", "helper"], "seeds": 5, "id": 9},
         assignment="a/b", with_plugin=True, result_url=True)
@example(drops=0, end={"kind": "refused", "status": 400, "field": "plugin", "error": "mine: no module"},
         assignment="a", with_plugin=True, result_url=False)
@example(drops=0, end={"kind": "garbage", "status": 201}, assignment="a", with_plugin=False, result_url=False)
@given(drops=st.integers(0, submit.SENDS), end=ends, assignment=NAMES, with_plugin=st.booleans(),
       result_url=st.booleans())
def test_submit_sends_one_key_however_often_and_says_what_the_server_said(
        server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        drops: int, end: dict[str, Any], assignment: str, with_plugin: bool, result_url: bool) -> None:
    reset(server)
    config = tmp_path / "robot.toml"
    config.write_text("[world]\nmax_time = 1.5  # 한국어\n", encoding="utf-8")
    plugin = tmp_path / "mine"
    (plugin / "sub").mkdir(parents=True, exist_ok=True)
    (plugin / "__init__.py").write_text("X = 1\n", encoding="utf-8")
    (plugin / "sub" / "deep.py").write_text("Y = 2\n", encoding="utf-8")
    (plugin / "notes.txt").write_text("not sent\n", encoding="utf-8")
    (plugin / "__pycache__").mkdir(exist_ok=True)
    (plugin / "__pycache__" / "junk.py").write_text("not sent\n", encoding="utf-8")
    if end["kind"] == "ok":
        body = {"id": end["id"], "assignment": assignment, "student": "kim", "seeds": end["seeds"],
                "late": end["late"], "plugins": end["plugins"]}
        final = Answer(end["status"], json.dumps(body))
    elif end["kind"] == "refused":
        final = Answer(end["status"], json.dumps({"error": end["error"], "field": end["field"]}), store=False)
    else:
        final = Answer(end["status"], "<html>oops</html>", store=False)
    server.script(*[Answer(reset=True, store=False)] * drops, then=final)
    pauses: list[float] = []
    monkeypatch.setattr(submit, "time", types.SimpleNamespace(sleep=pauses.append, monotonic=lambda: 0.0))
    monkeypatch.setenv("ROBOKIT_TOKEN", "  t0ken-kim  ")
    base = server.url if result_url else server.url.split("/api/")[0] + "/"
    args = argparse.Namespace(url=base, token_env="ROBOKIT_TOKEN", assignment=assignment, config=str(config),
                              plugin=str(plugin) if with_plugin else None, wait=False, wait_seconds=1.0)
    capsys.readouterr()
    code = submit.cmd_submit(args)
    out, err = capsys.readouterr()

    sends = min(drops + 1, submit.SENDS)
    assert len(server.requests) == sends and len(pauses) == sends - 1
    assert pauses == sorted(pauses) and all(p > 0 for p in pauses)  # waits, growing, between sends
    keys = server.keys()
    assert keys[0] and len(keys[0]) >= 16 and set(keys) == {keys[0]}  # one key for every send
    for rec in server.requests:
        assert rec.path == f"/api/robotics/assignments/{quote(assignment, safe='')}/submissions/"
        assert rec.headers["authorization"] == "Bearer t0ken-kim"
        want = {"config": config.read_text(encoding="utf-8")}
        if with_plugin:
            want["plugin_files"] = {"mine/__init__.py": "X = 1\n", "mine/sub/deep.py": "Y = 2\n"}
        assert rec.json() == want
    if drops >= submit.SENDS:
        assert code == submit.EXIT_UNREACHABLE and out == ""
        assert err.count("\n") == 1 and err.startswith("robokit: error: cannot reach ")
        return
    if end["kind"] == "ok":
        late = " (late)" if end["late"] else ""
        mine = f" with your plugin {', '.join(end['plugins'])}" if end["plugins"] else ""
        assert code == 0 and err == ""
        assert out == (f"submitted{late}: submission {end['id']} of {assignment!r} for kim{mine}, queued for "
                       f"official evaluation on {end['seeds']} seeds\n")
        return
    assert code == submit.EXIT_REFUSED and out == "" and err.count("\n") == 1
    if end["kind"] == "refused":
        where = str(plugin) if end["field"] == "plugin" and with_plugin else str(config)
        said = end["error"] or str(end["status"])
        assert err == f"robokit: error: {where}: {said}\n"
    else:
        said = "(not JSON)" if end["status"] >= 300 else "(not the course server's answer)"
        assert err == f"robokit: error: {config}: HTTP {end['status']} {said}\n"


def test_submit_refuses_bad_input_in_one_line_before_sending(server: CourseServer, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    reset(server)
    config = tmp_path / "robot.toml"
    config.write_text("[world]\n", encoding="utf-8")

    def args(**kw: Any) -> argparse.Namespace:
        base = dict(url=server.url, token_env="MY_TOKEN", assignment="a", config=str(config), plugin=None,
                    wait=False, wait_seconds=1.0)
        return argparse.Namespace(**{**base, **kw})

    monkeypatch.setenv("MY_TOKEN", "tok")
    cases = [(args(url=None), "--url"), (args(url="ftp://x/"), "--url: expected http://HOST:PORT/"),
             (args(url="http:///nohost"), "--url"), (args(config=str(tmp_path / "missing.toml")), "missing.toml"),
             (args(plugin=str(tmp_path / "robot.toml")), "--plugin"), (args(plugin=str(tmp_path)), None)]
    (tmp_path / "empty").mkdir()
    cases[-1] = (args(plugin=str(tmp_path / "empty")), "no .py files")
    for a, said in cases:
        with pytest.raises(UserError) as exc:
            submit.cmd_submit(a)
        assert said in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(UserError) as exc:
        submit.cmd_submit(args(url=None))
    assert str(exc.value) == "--url: say where the course server is (or set ROBOKIT_SERVER_URL)"
    missing = tmp_path / "missing.toml"
    with pytest.raises(UserError) as exc:
        submit.cmd_submit(args(config=str(missing)))
    assert str(exc.value) == f"{missing}: cannot read the config: No such file or directory"
    latin = tmp_path / "latin.toml"
    latin.write_bytes("name = 'caf\u00e9'\n".encode("latin-1"))
    with pytest.raises(UserError) as exc:
        submit.cmd_submit(args(config=str(latin)))
    assert str(exc.value).startswith(f"{latin}: cannot read the config: 'utf-8' codec can't decode")
    for token in ("   ", None):
        if token is None:
            monkeypatch.delenv("MY_TOKEN", raising=False)
        else:
            monkeypatch.setenv("MY_TOKEN", token)
        with pytest.raises(UserError) as exc:
            submit.cmd_submit(args())
        assert str(exc.value) == "no token: export MY_TOKEN=<the token your teacher gave you>"
    assert server.requests == []  # nothing was sent for any of them


@pytest.mark.parametrize(("address", "name", "want"), [
    ("https://course.example.org:8443/", "drop test", "https://course.example.org:8443/api/robotics/assignments/"
                                                      "drop%20test/submissions/"),
    ("http://10.0.0.5:8000/api/robotics/result/", "a/b?c#d", "http://10.0.0.5:8000/api/robotics/assignments/"
                                                              "a%2Fb%3Fc%23d/submissions/"),
    (" http://h/ ", "주행", "http://h/api/robotics/assignments/%EC%A3%BC%ED%96%89/submissions/"),
])
def test_the_submission_url_comes_from_the_servers_address_and_the_quoted_name(address: str, name: str,
                                                                               want: str) -> None:
    assert submit.submit_url(address, name) == want


trials = st.lists(st.fixed_dictionaries({"seed": st.integers(0, 99),
                                         "outcome": st.sampled_from(["succeeded", "failed", "aborted", "error"]),
                                         "reason": st.sampled_from(["", "the cube fell off"])}), max_size=4)


@SETTINGS
@example(steps=["queued", "running"], final="401", found=[], wilson=None)
@example(steps=["queued", "500", "running"], final="error", found=[{"seed": 1, "outcome": "error", "reason": ""}],
         wilson=None)
@example(steps=["running", "garbage", "queued"], final="done",
         found=[{"seed": 0, "outcome": "succeeded", "reason": "the cube fell off"}], wilson=(0.1234, 0.9876))
@example(steps=["queued"], final="never", found=[], wilson=None)
@given(steps=st.lists(st.sampled_from(["queued", "running", "drop", "garbage", "500"]), max_size=5),
       final=st.sampled_from(["done", "error", "401", "never"]), found=trials,
       wilson=st.sampled_from([None, (0.1234, 0.9876)]))
def test_wait_follows_to_the_grade_and_prints_every_trial(
        httpserver: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], steps: list[str],
        final: str, found: list[dict[str, Any]], wilson: Any) -> None:
    httpserver.clear()
    queue = [*steps, final] if final != "never" else [*steps, "queued"]
    succeeded = sum(t["outcome"] == "succeeded" for t in found)
    rate = succeeded / len(found) if found else None
    done = {"id": 3, "status": "done", "trials": found, "succeeded": succeeded, "success_rate": rate,
            "wilson95": list(wilson) if wilson else [None, None], "note": ""}
    for step in queue:
        expect = httpserver.expect_ordered_request("/s/")
        if step in ("queued", "running"):
            expect.respond_with_json({"id": 3, "status": step, "note": ""})
        elif step == "done":
            expect.respond_with_json(done)
        elif step == "error":
            expect.respond_with_json({"id": 3, "status": "error", "trials": found, "error": "engine crashed"})
        elif step == "401":
            expect.respond_with_json({"error": "token revoked"}, status=401)
        elif step == "500":
            expect.respond_with_data("busy", status=500)
        else:  # "drop" and "garbage": an answer that is not JSON
            expect.respond_with_data("<html>", status=200)
    clock = [0.0]
    pauses: list[float] = []

    def sleep(s: float) -> None:
        pauses.append(s)
        clock[0] += s

    limit = sum(min(0.5 * 1.5 ** i, 5.0) for i in range(len(queue))) - 0.01
    monkeypatch.setattr(submit, "time", types.SimpleNamespace(monotonic=lambda: clock[0], sleep=sleep))
    code = submit.follow(httpserver.url_for("/s/"), {}, limit, sleep=sleep)
    out, err = capsys.readouterr()
    assert pauses == pytest.approx([min(0.5 * 1.5 ** i, 5.0) for i in range(len(pauses))])
    shown: list[str] = []
    for step in queue:
        if step in ("queued", "running") and (not shown or shown[-1] != f"{step}..."):
            shown.append(f"{step}...")
    lines = out.splitlines()
    assert [line for line in lines if line.endswith("...")] == shown
    trial_lines = [f"  seed {t['seed']}: {t['outcome']}" + (f" - {t['reason']}" if t["reason"] else "")
                   for t in found]
    if final == "done":
        bounds = f", 95 % {wilson[0]:.2f}-{wilson[1]:.2f}" if wilson else ""
        shown_rate = "None" if rate is None else f"{rate:.2f}"
        assert code == 0 and err == ""
        assert lines[len(shown):] == trial_lines + [
            f"graded: {succeeded}/{len(found)} official trials succeeded (success rate {shown_rate}{bounds})"]
    elif final == "error":
        assert code == submit.EXIT_NOT_GRADED and lines[len(shown):] == trial_lines
        assert err == "robokit: error: submission 3 could not be evaluated: engine crashed\n"
    elif final == "401":
        assert code == submit.EXIT_REFUSED and err == "robokit: error: cannot follow the submission: token revoked\n"
    else:
        assert code == submit.EXIT_STILL_WAITING and err.count("\n") == 1 and "still " in err


@pytest.mark.parametrize("answer", ["<html>captive portal</html>", "[1, 2]", '{"ok": true}'])
def test_a_2xx_that_is_not_the_course_servers_answer_is_one_error_line(
        server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        answer: str) -> None:
    """A URL that reaches something other than the course server (a captive portal, a proxy's page) answers 200
    with a page: one line saying so and a non-zero exit, never a traceback."""
    reset(server)
    config = tmp_path / "robot.toml"
    config.write_text("[world]\n", encoding="utf-8")
    server.script(then=Answer(200, answer, store=False))
    monkeypatch.setenv("ROBOKIT_TOKEN", "tok")
    args = argparse.Namespace(url=server.url, token_env="ROBOKIT_TOKEN", assignment="a", config=str(config),
                              plugin=None, wait=False, wait_seconds=1.0)
    capsys.readouterr()
    code = submit.cmd_submit(args)
    out, err = capsys.readouterr()
    assert code == submit.EXIT_REFUSED and out == "" and err.count("\n") == 1
    assert err.startswith(f"robokit: error: {config}: HTTP 200") and len(server.requests) == 1


def test_a_server_that_is_down_is_tried_every_time_then_one_line_and_exit_4(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from report_server import closed_port_url

    config = tmp_path / "robot.toml"
    config.write_text("[world]\n", encoding="utf-8")
    pauses: list[float] = []
    monkeypatch.setattr(submit, "time", types.SimpleNamespace(sleep=pauses.append, monotonic=lambda: 0.0))
    monkeypatch.setenv("ROBOKIT_TOKEN", "tok")
    url = closed_port_url()
    args = argparse.Namespace(url=url, token_env="ROBOKIT_TOKEN", assignment="a b", config=str(config),
                              plugin=None, wait=True, wait_seconds=1.0)
    capsys.readouterr()
    assert submit.cmd_submit(args) == submit.EXIT_UNREACHABLE
    out, err = capsys.readouterr()
    assert out == "" and len(pauses) == submit.SENDS - 1
    assert err == f"robokit: error: cannot reach {submit.submit_url(url, 'a b')}: ConnectionError\n"
    assert submit.submit_url(url, "a b").endswith("/api/robotics/assignments/a%20b/submissions/")


def test_a_plugin_module_or_package_is_sent_as_its_py_files(tmp_path: Path) -> None:
    module = tmp_path / "mine.py"
    module.write_text("X = 1\n", encoding="utf-8")
    assert submit.plugin_files(str(module)) == {"mine.py": "X = 1\n"}
    bad = tmp_path / "pkg"
    bad.mkdir()
    (bad / "a.py").write_bytes(b"\xff\xfe")
    with pytest.raises(UserError) as exc:
        submit.plugin_files(str(bad))
    assert str(exc.value).startswith(f"--plugin {bad}: 'utf-8' codec can't decode")


def test_an_answer_with_exactly_the_submissions_fields_is_a_submission(
        server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    reset(server)
    config = tmp_path / "robot.toml"
    config.write_text("[world]\n", encoding="utf-8")
    server.script(then=Answer(201, json.dumps({"id": 4, "assignment": "a", "student": "kim", "seeds": 3})))
    monkeypatch.setenv("ROBOKIT_TOKEN", "tok")
    args = argparse.Namespace(url=server.url, token_env="ROBOKIT_TOKEN", assignment="a", config=str(config),
                              plugin=None, wait=False, wait_seconds=1.0)
    capsys.readouterr()
    assert submit.cmd_submit(args) == 0
    assert capsys.readouterr().out == ("submitted: submission 4 of 'a' for kim, queued for official evaluation on "
                                       "3 seeds\n")
