"""What a run writes and reports (docs/cli.md "Exit codes", docs/records.md, :mod:`robokit.core.result`), as
properties over generated results.

* ``RunResult.to_dict()``: every field, ``schema`` first, strict JSON (NaN and infinities as null, numpy values as
  plain numbers and lists, tuples as lists, keys as strings, anything else as its text).
* Exit codes: by outcome (0 succeeded, 1 failed or aborted, 3 error, 130 interrupted), and for the finished run the
  first that applies, top down: 130 / 143 (by the signal), 4 (kept nowhere), the outcome's code, 6 for a success
  whose record is incomplete; the real-time factor is sim time over wall time.
* The summary a run prints: the outcome and its reason, the times to two decimals, the real-time factor to one (``-``
  without a wall time), each result entry (a long one cut at 200 characters), each warning once, each reporter's
  line (a refusal is said elsewhere), and a WARNING when the result is kept nowhere.
* A run that ended before its first tick (a plugin raised in setup, a signal): every field whole (version, config,
  behaviour, engine, seed, zero ticks and times, the start in UTC to the second).
* A run stopped before its config was loaded: the result file goes to the config's ``[report.local] dir``, with its
  seed (``--seed`` first), behaviour type, student and project, written whole (no temporary file left behind).
* The trace writer: one JSON object per line; a write that fails stops the trace with one line naming the file and
  the tick.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import itertools
import json
import math
import uuid
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import robokit
from robokit.components import Delivery
from robokit.core.result import OUTCOME_EXIT_CODES, RunResult, early_result, write_early_result
from robokit.report.reporting import Refused
from robokit.runner import RunOutput, TraceWriter, error_result, summary

FAST = settings(max_examples=20, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])

OUTCOMES = ["succeeded", "failed", "aborted", "error"]
FIELDS = ["schema", "run_id", "robokit_version", "config", "behaviour", "seed", "outcome", "reason", "ticks",
          "sim_time", "wall_time", "started_at", "result", "interrupted", "warnings", "engine", "engine_version"]

finite = st.floats(-1e6, 1e6, allow_nan=False)
numbers = st.one_of(finite, st.sampled_from([math.nan, math.inf, -math.inf]), st.integers(-10**9, 10**9))


def plain(value: Any) -> Any:
    """What strict JSON should carry, computed here: numpy to Python, tuples to lists, non-finite to None."""
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, np.generic):
        return plain(value.item())
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


class Tag:
    def __str__(self) -> str:
        return "tag!"


leaves = st.one_of(
    numbers, st.booleans(), st.none(), st.text(max_size=4),
    numbers.map(np.float64), st.integers(-1000, 1000).map(np.int64), st.booleans().map(np.bool_),
    st.lists(numbers, max_size=4).map(lambda xs: np.array(xs, dtype=float)),
    st.lists(st.lists(finite, min_size=2, max_size=2), min_size=1, max_size=3).map(np.array),
    st.just(Tag()))
trees = st.recursive(leaves, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.tuples(inner, inner),
    st.dictionaries(st.one_of(st.text(max_size=3), st.integers(0, 9)), inner, max_size=3)), max_leaves=10)


def make(**fields: Any) -> RunResult:
    base: dict[str, Any] = {"run_id": "r1", "robokit_version": "0.0", "config": "c.toml", "behaviour": "b", "seed": 0,
                            "outcome": "succeeded", "reason": "", "ticks": 0, "sim_time": 0.0, "wall_time": 0.0,
                            "started_at": "2000-01-01T00:00:00+00:00"}
    return RunResult(**{**base, **fields})


@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(result=st.dictionaries(st.text(max_size=5), trees, max_size=4), sim_time=numbers, wall_time=numbers,
       seed=st.integers(0, 2**63), ticks=st.integers(0, 10**7), outcome=st.sampled_from(OUTCOMES),
       interrupted=st.booleans(), warnings=st.lists(st.text(max_size=8), max_size=3),
       engine=st.sampled_from([None, "pybullet", "mujoco"]))
def test_a_result_is_every_field_in_strict_json(result: dict[str, Any], sim_time: float, wall_time: float, seed: int,
                                                ticks: int, outcome: str, interrupted: bool, warnings: list[str],
                                                engine: str | None) -> None:
    r = make(result=result, sim_time=sim_time, wall_time=wall_time, seed=seed, ticks=ticks, outcome=outcome,
             interrupted=interrupted, warnings=warnings, engine=engine, engine_version="1.2" if engine else None)
    back = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert list(back) == FIELDS  # the schema first, then the fields in their documented order
    assert back["schema"] == "robokit.run/1"
    want = {f.name: plain(getattr(r, f.name)) for f in dataclasses.fields(r)}
    assert {k: back[k] for k in want} == want
    assert r.to_dict()["result"] == plain(result)  # the dict itself, not only its JSON, is plain


@FAST
@given(outcome=st.sampled_from(OUTCOMES), interrupted=st.booleans(), sim_time=st.floats(0, 1e4),
       wall_time=st.floats(0, 1e4))
def test_exit_code_and_real_time_factor_of_a_result(outcome: str, interrupted: bool, sim_time: float,
                                                    wall_time: float) -> None:
    r = make(outcome=outcome, interrupted=interrupted, sim_time=sim_time, wall_time=wall_time)
    want = 130 if interrupted else {"succeeded": 0, "failed": 1, "aborted": 1, "error": 3}[outcome]
    assert r.exit_code == want
    if wall_time > 0:
        assert r.real_time_factor == sim_time / wall_time
    else:
        assert r.real_time_factor == math.inf


deliveries = st.lists(st.tuples(st.sampled_from(["local", "http", "mine"]), st.one_of(
    st.builds(Delivery, st.booleans(), st.sampled_from([None, "results/x/result.json"]), st.text(max_size=10)),
    st.builds(lambda m: Refused(False, None, m, why="no", advice="fix", status=401), st.text(max_size=6)))),
    max_size=3)


@FAST
@given(outcome=st.sampled_from(OUTCOMES), result_interrupted=st.booleans(), out_interrupted=st.booleans(),
       signal=st.sampled_from([None, "SIGINT", "SIGTERM"]), term_in_reason=st.booleans(), got=deliveries,
       failures=st.lists(st.text(min_size=1, max_size=6), max_size=2))
def test_the_exit_code_of_a_run_is_the_first_that_applies_top_down(
        outcome: str, result_interrupted: bool, out_interrupted: bool, signal: str | None, term_in_reason: bool,
        got: list[tuple[str, Delivery]], failures: list[str]) -> None:
    reason = "interrupted by SIGTERM at t = 1.00 s" if term_in_reason else "interrupted by SIGINT at t = 1.00 s"
    r = make(outcome=outcome, interrupted=result_interrupted, reason=reason)
    out = RunOutput(r, r.to_dict(), list(got), interrupted=out_interrupted, signal=signal,
                    record_failures=list(failures))
    stored = not got or any(d.delivered or d.stored for _, d in got)
    assert out.stored == stored
    if out_interrupted or result_interrupted:
        named = signal or ("SIGTERM" if term_in_reason else None)  # else the reason names it
        want = 143 if named == "SIGTERM" else 130
    elif not stored:
        want = 4
    elif outcome == "error":
        want = 3
    elif outcome in ("failed", "aborted"):
        want = 1
    else:
        want = 6 if failures else 0
    assert out.exit_code == want


entries = st.dictionaries(st.text("abcxyz_", min_size=1, max_size=6), st.one_of(
    st.integers(-99, 99), st.text("abc ", max_size=8),
    st.lists(st.integers(0, 10**6), max_size=40),
    st.dictionaries(st.text("ab", max_size=3), st.integers(), max_size=3)),
    max_size=4)


@FAST
@given(outcome=st.sampled_from(OUTCOMES), reason=st.text("abc :=", max_size=12), sim_time=st.floats(0, 1e3),
       wall_time=st.sampled_from([0.0, 0.004, 0.5, 3.25, 40.0]), result=entries,
       warnings=st.lists(st.text("wxyz", min_size=1, max_size=5), max_size=3, unique=True),
       failures=st.lists(st.text("wxyz", min_size=1, max_size=5), max_size=3, unique=True), got=deliveries)
def test_the_summary_says_each_figure_entry_warning_and_delivery_once(
        outcome: str, reason: str, sim_time: float, wall_time: float, result: dict[str, Any], warnings: list[str],
        failures: list[str], got: list[tuple[str, Delivery]]) -> None:
    r = make(outcome=outcome, reason=reason, sim_time=sim_time, wall_time=wall_time, result=result,
             warnings=list(warnings))
    out = RunOutput(r, r.to_dict(), list(got), record_failures=list(failures))
    lines = summary(out).split("\n")
    assert lines[0] == f"outcome: {outcome}" + (f" ({reason})" if reason else "")
    times = lines[1].split()
    assert times[2] == f"{round(sim_time, 2):.2f}" and float(times[2]) == pytest.approx(sim_time, abs=0.005 + 1e-9)
    assert times[6] == f"{wall_time:.2f}"
    factor = times[-1]
    assert factor == "-" if wall_time == 0 else float(factor[:-1]) == pytest.approx(sim_time / wall_time, abs=0.05 +
                                                                                    1e-9 * sim_time / wall_time)
    rest = lines[2:]
    for i, (key, value) in enumerate(result.items()):
        line = rest[i]
        assert line.startswith(f"  {key}: ")
        shown = line[len(f"  {key}: "):]
        if isinstance(value, (dict, list)):
            text = json.dumps(value)
            assert shown == text if len(text) <= 200 else (len(shown) == 200 and shown.endswith("...")
                                                           and text.startswith(shown[:-3]))
        else:
            assert shown == str(value)
    said = [line[len("warning: "):] for line in rest if line.startswith("warning: ")]
    assert said == warnings + [f for f in failures if f not in warnings]
    reports = [line for line in rest if line.startswith("report[")]
    assert reports == [f"report[{n}]: {d.message or ('delivered' if d.delivered else 'not delivered')}"
                       for n, d in got if not isinstance(d, Refused)]
    stored = not got or any(d.delivered or d.stored for _, d in got)
    assert (rest[-1:] == ["WARNING: the result could not be delivered or stored anywhere"]) == (not stored)
    assert len(rest) == len(result) + len(said) + len(reports) + (not stored)


def utc_now_seconds() -> dt.datetime:
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0)


def started_now(text: str, before: dt.datetime) -> bool:
    """An ISO time in UTC, to the second, taken during the call."""
    when = dt.datetime.fromisoformat(text)
    return when.utcoffset() == dt.timedelta(0) and when.microsecond == 0 and before <= when <= utc_now_seconds()


@settings(max_examples=5, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(folder=st.one_of(st.none(), st.sampled_from(["out", "runs/here"]), st.integers(0, 3)),
       world_seed=st.one_of(st.integers(0, 10**6), st.none(), st.just("7")), seed=st.integers(0, 99),
       behaviour=st.one_of(st.none(), st.sampled_from(["sort", "patrol"]), st.just(3)),
       student=st.one_of(st.none(), st.just("kim"), st.just(5)), project=st.one_of(st.none(), st.just("hw1")),
       signal_name=st.sampled_from(["SIGINT", "SIGTERM"]))
def test_a_run_stopped_before_its_config_loaded_keeps_what_the_config_says(
        tmp_path: Path, folder: Any, world_seed: Any, seed: int, behaviour: Any, student: Any,
        project: str | None, signal_name: str) -> None:
    lines = []
    if world_seed is not None:
        lines += ["[world]", f"seed = {json.dumps(world_seed)}"]
    if behaviour is not None:
        lines += ["[behaviour]", f"type = {json.dumps(behaviour)}"]
    if student is not None or project is not None or folder is not None:
        lines += ["[report]"] + [f"{k} = {json.dumps(v)}" for k, v in (("student", student), ("project", project))
                                 if v is not None]
        if folder is not None:
            lines += ["[report.local]", f"dir = {json.dumps(folder)}"]
    config = tmp_path / "c.toml"
    for broken, given_seed in itertools.product((False, True), (None, seed)):
        config.write_text("\n".join(lines) + ("\n[[[ not toml" if broken else "\n"))
        before = utc_now_seconds()
        path, payload = early_result(str(config), signal_name, seed=given_seed)
        ok = not broken  # an unreadable config: the defaults
        want_folder = Path(folder) if ok and isinstance(folder, str) else Path("results")
        assert path == want_folder / payload["run_id"] / "result.json"
        want_seed = given_seed if given_seed is not None else world_seed if ok and isinstance(world_seed, int) else 0
        assert payload["seed"] == want_seed
        assert payload["behaviour"] == (behaviour if ok and isinstance(behaviour, str) else None)
        assert payload.get("student") == (student if ok and isinstance(student, str) else None)
        assert payload.get("project") == (project if ok else None)
        assert payload["outcome"] == "aborted" and payload["interrupted"] is True and payload["ticks"] == 0
        assert payload["sim_time"] == 0.0 and payload["wall_time"] == 0.0 and payload["result"] == {}
        assert payload["robokit_version"] == robokit.__version__ and payload["schema"] == "robokit.run/1"
        assert started_now(payload["started_at"], before) and uuid.UUID(payload["run_id"]).version == 4
        assert payload["reason"] == f"interrupted by {signal_name} during start-up (before the config was loaded)"
        assert payload["config"] == str(config)
        target = tmp_path / "keep" / path
        write_early_result(target, {"stale": True})
        write_early_result(target, payload)  # over a file already there, in a folder already there
        assert json.loads(target.read_text()) == payload
        assert [p.name for p in target.parent.iterdir()] == ["result.json"]  # no temporary file left
    blocked = tmp_path / "blocked" / "result.json"
    (blocked / "inside").mkdir(parents=True, exist_ok=True)  # a folder where the file should go: no rename
    with pytest.raises(OSError):
        write_early_result(blocked, {"seed": seed})
    assert sorted(p.name for p in blocked.parent.iterdir()) == ["result.json"]  # the temporary file is removed


@pytest.fixture(scope="module")
def configs(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[bool, str], Any]:
    """Four loaded configs: with and without a behaviour, on each engine."""
    from robokit.config import load_config
    from robokit.plugin_api.plugins import load_plugins

    folder, plugins, out = tmp_path_factory.mktemp("configs"), load_plugins(), {}
    for behaviour, engine in itertools.product((True, False), ("pybullet", "mujoco")):
        text = f'[world]\nengine = "{engine}"\n[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'
        text += '[behaviour]\ntype = "record"\n' if behaviour else ""
        path = folder / f"{behaviour}-{engine}.toml"
        path.write_text(text)
        out[(behaviour, engine)] = load_config(path, plugins)
    return out


@FAST
@given(which=st.sampled_from([(True, "pybullet"), (False, "pybullet"), (True, "mujoco"), (False, "mujoco")]),
       seed=st.integers(0, 2**40), reason=st.text(max_size=20), run_id=st.one_of(st.none(), st.just("given-id")),
       outcome=st.sampled_from(["error", "aborted"]), interrupted=st.one_of(st.none(), st.booleans()))
def test_a_run_that_ended_before_its_first_tick_has_a_whole_result(
        configs: dict[tuple[bool, str], Any], which: tuple[bool, str], seed: int, reason: str, run_id: str | None,
        outcome: str, interrupted: bool | None) -> None:
    cfg = configs[which]
    options: dict[str, Any] = {"run_id": run_id, "outcome": outcome}
    if interrupted is not None:
        options["interrupted"] = interrupted
    before = utc_now_seconds()
    r = error_result(cfg, seed, reason, **options)
    data = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert data["run_id"] == run_id if run_id else uuid.UUID(data["run_id"]).version == 4
    assert data["robokit_version"] == robokit.__version__ and data["config"] == cfg.source
    assert data["behaviour"] == ("record" if which[0] else None) and data["engine"] == which[1]
    assert data["seed"] == seed and data["outcome"] == outcome and data["reason"] == reason
    assert data["ticks"] == 0 and data["sim_time"] == 0.0 and data["wall_time"] == 0.0 and data["result"] == {}
    assert data["interrupted"] is bool(interrupted) and started_now(data["started_at"], before)
    assert r.exit_code == (130 if interrupted else OUTCOME_EXIT_CODES[outcome])


@settings(max_examples=10, deadline=None, derandomize=True, database=None)
@given(records=st.lists(st.fixed_dictionaries({"tick": st.integers(0, 10**6), "t": finite,
                                               "value": st.one_of(finite, st.text(max_size=5))}),
                        min_size=1, max_size=6))
def test_the_trace_writer_writes_a_line_per_record_and_stops_at_a_failed_write(records: list[dict[str, Any]]) -> None:
    import io

    buffer = io.StringIO()
    writer = TraceWriter(buffer)
    for record in records:
        writer(record)
    assert [json.loads(line) for line in buffer.getvalue().splitlines()] == records and writer.failure is None
    full = open("/dev/full", "w", buffering=1, encoding="utf-8")  # noqa: SIM115 - every write: "No space left"
    try:
        writer = TraceWriter(full)
        for record in records:
            writer(record)
        assert writer.failure == (f"trace writer: writing /dev/full failed at tick {records[0]['tick']}: No space "
                                  "left on device; the trace stops there")
    finally:
        with contextlib.suppress(OSError):  # what the failed line left in the buffer cannot be flushed either
            full.close()
