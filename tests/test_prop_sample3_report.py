"""Reporting's ordering and resend promises, against a real HTTP server on 127.0.0.1.

* ``deliver`` runs the local reporters first (robokit.report.reporting: "local reporters are run first"), so a slow
  or hanging server never delays the local copy, whatever order the config lists the reporters in. The oracle is the
  server itself: when a result arrives over HTTP, every local reporter's ``result.json`` is already on disk.
* ``robokit submit`` sends one fresh ``Idempotency-Key`` and sends it *again* if the connection fails before the
  answer (docs: "however often it is resent, it is one submission"): a server that drops the first connections sees
  one key on every request, and stores one submission. The pauses between sends are skipped (recorded instead).
"""

from __future__ import annotations

import argparse
import itertools
import json
import types
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer, Recorded, make_payload
from robokit_plugins.http_report import HttpReportConfig, HttpReporter
from robokit_plugins.local_report import LocalReportConfig, LocalReporter

from robokit.report import submit
from robokit.report.reporting import deliver

pytest_plugins = ["report_props"]

COUNTER = itertools.count()


@settings(max_examples=8, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kinds=st.lists(st.sampled_from(["local", "http"]), min_size=2, max_size=4).filter(
    lambda k: "local" in k and "http" in k))
def test_every_local_copy_exists_before_the_server_sees_the_result(server: CourseServer, tmp_path: Path,
                                                                  kinds: list[str]) -> None:
    n = next(COUNTER)
    root = tmp_path / f"ex{n}"
    payload = make_payload(1000 + n)
    result_files: list[Path] = []
    reporters: list[Any] = []
    for i, kind in enumerate(kinds):
        if kind == "local":
            folder = root / f"local{i}"
            result_files.append(folder / payload["run_id"] / "result.json")
            reporters.append(LocalReporter(f"local{i}", LocalReportConfig(dir=str(folder))))
        else:
            reporters.append(HttpReporter(f"http{i}", HttpReportConfig(
                url=server.url, outbox=str(root / f"outbox{i}"), retries=0, flush_outbox=False)))
    seen: list[list[bool]] = []

    def on_request(rec: Recorded) -> None:
        seen.append([f.is_file() for f in result_files])

    server.on_request = on_request
    out = deliver(reporters, payload)
    assert sorted(name for name, _ in out) == sorted(r.name for r in reporters)  # each ran, once
    assert all(d.delivered for _, d in out), out
    assert len(seen) == kinds.count("http")
    assert all(all(row) for row in seen), f"a result reached the server before a local copy was kept: {seen}"
    for f in result_files:
        assert json.loads(f.read_text())["run_id"] == payload["run_id"]


ANSWER = json.dumps({"id": 7, "assignment": "drop", "student": "kim", "seeds": 2, "late": False})


@pytest.mark.parametrize("drops", [0, 1, submit.SENDS - 1])
def test_a_resent_submission_carries_one_key(server: CourseServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str], drops: int) -> None:
    config = tmp_path / "robot.toml"
    config.write_text("[world]\nmax_time = 1.0\n", encoding="utf-8")
    server.script(*[Answer(reset=True)] * drops, then=Answer(status=201, body=ANSWER))
    pauses: list[float] = []
    monkeypatch.setattr(submit, "time", types.SimpleNamespace(sleep=pauses.append))  # no wall-clock waits here
    monkeypatch.setenv("ROBOKIT_TOKEN", "t0ken")
    args = argparse.Namespace(url=server.url, token_env="ROBOKIT_TOKEN", assignment="drop", config=str(config),
                              plugin=None, wait=False, wait_seconds=1.0)
    assert submit.cmd_submit(args) == 0
    keys = server.keys()
    assert len(keys) == drops + 1 and len(pauses) == drops
    assert keys[0] and len(set(keys)) == 1, keys  # the same key on every send
    assert len(server.stored) == 1
    assert "submitted: submission 7" in capsys.readouterr().out
