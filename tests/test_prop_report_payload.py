"""``robokit.report.reporting`` as properties: the payload, the reporters' order and faults, the atomic writes.

* The payload is the RunResult's dict with ``student`` / ``project`` when given and the course fields
  (``red_sorted``, ``blue_sorted``, ``failures``, ``total_time``) copied to the top level when the result has them,
  and no folder of the machine that made it (the config relative to the working folder or by name alone; the
  working folder, Python's prefix and the home folder written portably in the reason and warnings).
* ``deliver`` runs every reporter once, the local ones first (whatever order the config lists them in), each
  group in its listed order; a reporter that raises is one failed, unstored delivery naming it, never an exception;
  a plain Ctrl-C with no stop guard is the user's and propagates.
* ``write_json_atomic`` leaves the complete file or the old one, never overwrites unless asked, leaves no
  temporary file.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.components import Delivery
from robokit.core.result import RunResult
from robokit.errors import Interrupted
from robokit.report.reporting import COURSE_FIELDS, build_payload, deliver, write_json_atomic

SETTINGS = settings(max_examples=15, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
KEYS = ["red_sorted", "blue_sorted", "green_sorted", "failures", "total_time", "picks", "note"]


def run_result(result: dict[str, Any], config: str, reason: str, warnings: list[str]) -> RunResult:
    return RunResult(run_id="00000000-0000-4000-8000-000000000001", robokit_version="0.1.0", config=config,
                     behaviour="sort", seed=3, outcome="succeeded", reason=reason, ticks=10, sim_time=1.0,
                     wall_time=0.1, started_at="2026-01-01T00:00:00+00:00", result=result, warnings=warnings)


@SETTINGS
@given(result=st.dictionaries(st.sampled_from(KEYS), st.one_of(st.integers(0, 9), st.floats(0, 99))),
       student=st.sampled_from([None, "kim", ""]), project=st.sampled_from([None, "A"]),
       where=st.sampled_from(["inside", "nested", "outside", "relative"]))
def test_the_payload_is_the_result_plus_the_course_fields_and_no_folder_of_this_machine(
        result: dict[str, Any], student: str | None, project: str | None, where: str) -> None:
    cwd = Path.cwd()
    home = Path.home()
    config = {"inside": str(cwd / "robot.toml"), "nested": str(cwd / "configs" / "sub" / "robot.toml"),
              "outside": "/elsewhere/x/robot.toml", "relative": "configs/robot.toml"}[where]
    reason = f"could not read {cwd / 'data' / 'map.png'}; see {home / 'notes.txt'}"
    warning = f"slow plugin {sys.prefix}{os.sep}lib{os.sep}x.py"
    r = run_result(result, config, reason, [warning])
    payload = build_payload(r, student=student, project=project)
    plain = r.to_dict()
    extra = {k: v for k, v in payload.items() if k not in plain}
    want_extra = {k: result[k] for k in COURSE_FIELDS if k in result}
    if student is not None:
        want_extra["student"] = student
    if project is not None:
        want_extra["project"] = project
    assert extra == want_extra
    assert {k: v for k, v in payload.items() if k in plain and k not in ("config", "reason", "warnings")} == {
        k: v for k, v in plain.items() if k not in ("config", "reason", "warnings")}
    assert payload["config"] == {"inside": "robot.toml", "nested": "configs/sub/robot.toml", "outside": "robot.toml",
                                 "relative": "configs/robot.toml"}[where]
    text = json.dumps(payload)
    assert str(cwd) + os.sep not in text and str(home) + os.sep not in text
    assert payload["reason"].startswith("could not read data/map.png; see ")
    assert payload["warnings"] == [f"slow plugin <python>{os.sep}lib{os.sep}x.py"]


class Probe:
    """A reporter that notes when it ran, then does what it was made to do."""

    def __init__(self, name: str, kind: str, log: list[str]) -> None:
        self.name, self.kind, self.log = name, kind, log
        self.sends = kind.startswith("remote")

    def report(self, payload: dict[str, Any]) -> Delivery:
        self.log.append(self.name)
        if self.kind.endswith("raises"):
            raise RuntimeError(f"{self.name} broke")
        if self.kind.endswith("interrupted"):
            raise Interrupted("SIGTERM")
        return Delivery(True, None, f"{self.name} ok {payload['run_id']}")

    def keep(self, payload: dict[str, Any]) -> Delivery:
        self.log.append(f"{self.name}:keep")
        return Delivery(False, "kept", "kept")


@SETTINGS
@given(kinds=st.lists(st.sampled_from(["local", "local_raises", "remote", "remote_raises", "remote_interrupted"]),
                      min_size=1, max_size=6),
       stopped=st.booleans())
def test_every_reporter_runs_once_local_ones_first_and_a_fault_is_one_failed_delivery(
        kinds: list[str], stopped: bool) -> None:
    log: list[str] = []
    reporters = [Probe(f"r{i}", kind, log) for i, kind in enumerate(kinds)]
    stop = type("Stop", (), {"signalled": stopped, "installed": True})()
    out = deliver(reporters, {"run_id": "x"}, stop=stop)
    local = [r for r in reporters if not r.sends]
    remote = [r for r in reporters if r.sends]
    assert [name for name, _ in out] == [r.name for r in local + remote]
    assert log == [r.name + (":keep" if stopped else "") for r in local + remote]  # once stopped, each keeps it
    for (name, d), r in zip(out, local + remote, strict=True):
        if stopped:
            assert d == Delivery(False, "kept", "kept")
        elif r.kind.endswith("raises"):
            assert not d.delivered and d.stored is None and d.message.startswith(f"{name}: RuntimeError")
            assert f"{name} broke" in d.message
        elif r.kind.endswith("interrupted"):
            assert not d.delivered and d.stored is None
            assert d.message == f"{name}: interrupted (SIGTERM) before the result was kept"
        else:
            assert d == Delivery(True, None, f"{name} ok x")


def test_a_ctrl_c_without_a_stop_guard_is_the_users_and_with_one_a_plugin_fault() -> None:
    class CtrlC(Probe):
        def report(self, payload: dict[str, Any]) -> Delivery:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        deliver([CtrlC("c", "local", [])], {"run_id": "x"})
    guard = type("Stop", (), {"signalled": False, "installed": True})()
    [(name, d)] = deliver([CtrlC("c", "local", [])], {"run_id": "x"}, stop=guard)
    assert name == "c" and not d.delivered and d.message.startswith("c: KeyboardInterrupt")


@SETTINGS
@given(first=st.dictionaries(st.text(max_size=5), st.integers()), second=st.dictionaries(st.text(max_size=5),
                                                                                         st.text(max_size=5)),
       overwrite=st.booleans())
def test_an_atomic_write_leaves_one_complete_file_and_never_overwrites_unless_asked(
        tmp_path: Path, first: dict[str, Any], second: dict[str, Any], overwrite: bool) -> None:
    folder = tmp_path / f"d{abs(hash((json.dumps(first), json.dumps(second), overwrite)))}" / "deeper"
    path = folder / "result.json"
    write_json_atomic(path, first)
    assert json.loads(path.read_text(encoding="utf-8")) == first
    if overwrite:
        write_json_atomic(path, second, overwrite=True)
        assert json.loads(path.read_text(encoding="utf-8")) == second
    else:
        with pytest.raises(FileExistsError):
            write_json_atomic(path, second)
        assert json.loads(path.read_text(encoding="utf-8")) == first
    assert sorted(p.name for p in folder.iterdir()) == ["result.json"]  # no temporary file left
    assert path.read_text(encoding="utf-8").endswith("}\n")
