"""Every summary row and export compared with the rows or trace it came from, over generated inputs.

A sweep's summary derives figures twice -- a rate and the per-trial flags it counts, a median and the values it is
the median of, a JUnit file and the rows it lists -- and a run record derives each machine's stays in its states
from the transition records. Here rows and traces are generated, and every derived number is recomputed plainly
from them: counts by counting, the Wilson bounds as the roots of the score equation (numpy's polynomial roots), the
median by sorting, the nearest-rank p95 by its definition, each JUnit test case and each Markdown line against its
row, each reproduce command parsed back with shlex, each span against a walk of the events.
"""

from __future__ import annotations

import html
import json
import math
import re
import shlex
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.record.export import state_changes
from robokit.record.format import RunRecord
from robokit.record.layout import TRACE_FILE
from robokit.record.page import build_page
from robokit.sweep.summary import failed_trials, summarise, to_markdown, write_junit

PROPS = settings(max_examples=60, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
Z = 1.959963984540054
OUTCOMES = ("succeeded", "failed", "aborted", "error")


def score_roots(k: int, n: int) -> tuple[float, float]:
    """Wilson's interval: the p where (k/n - p)^2 = z^2 p (1 - p) / n, as the roots of that quadratic in p."""
    phat = k / n
    # (1 + z^2/n) p^2 - (2 phat + z^2/n) p + phat^2 = 0
    roots = np.roots([1 + Z * Z / n, -(2 * phat + Z * Z / n), phat * phat]).real
    return float(min(roots)), float(max(roots))


figure_value = st.one_of(st.floats(-1e6, 1e6, allow_nan=False), st.integers(-1000, 1000), st.none(), st.booleans(),
                         st.just(float("nan")), st.just("text"))


@st.composite
def sweeps(draw: Any) -> tuple[list[dict[str, Any]], list[str]]:
    cells = draw(st.lists(st.sampled_from(["base", "mass=0.5", "mass=2", "friction=0.1"]), min_size=1, max_size=3,
                          unique=True))
    rows = []
    for i in range(draw(st.integers(0, 25))):
        cell = draw(st.sampled_from(cells))
        figures = draw(st.dictionaries(st.sampled_from(["score", "placed", "error_mm"]), figure_value, max_size=3))
        rows.append({"key": f"{cell}/{i}", "cell": cell, "seed": i, "overrides": {} if cell == "base" else
                     {cell.split("=")[0]: float(cell.split("=")[1])}, "outcome": draw(st.sampled_from(OUTCOMES)),
                     "reason": draw(st.sampled_from(["", "dropped it", "a 'quoted' reason", "시간 초과"])),
                     "run_id": f"run-{i}", "sim_time": draw(st.floats(0, 100)), "wall_time": draw(st.floats(0, 5)),
                     "figures": figures, "worker": i % 2,
                     **draw(st.sampled_from([{}, {"record": f"out/records/{cell}-{i}"}, {"record": None}])),
                     **draw(st.sampled_from([{}, {"engine": "pybullet", "engine_version": "3.2.6"},
                                             {"engine": "mujoco", "engine_version": "3.3.0"}, {"engine": "mujoco"}]))})
    return rows, cells


def plain_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


@settings(PROPS, max_examples=25)
@given(sweeps())
def test_every_summary_figure_is_recomputed_from_the_rows(sweep: tuple[list[dict[str, Any]], list[str]]) -> None:
    rows, cells = sweep
    summary = summarise(rows, cells)
    assert [c["cell"] for c in summary["cells"]] == cells
    assert summary["trials"] == len(rows)
    assert summary["succeeded"] == len([r for r in rows if r["outcome"] == "succeeded"])
    assert summary["errors"] == len([r for r in rows if r["outcome"] == "error"])
    named = sorted({k for r in rows for k, v in r["figures"].items() if plain_number(v)})
    assert summary["metrics"] == named
    for c in summary["cells"]:
        mine = [r for r in rows if r["cell"] == c["cell"]]
        ok = len([r for r in mine if r["outcome"] == "succeeded"])
        assert (c["trials"], c["succeeded"]) == (len(mine), ok)
        assert c["errors"] == len([r for r in mine if r["outcome"] == "error"])
        engines = {" ".join(v for v in (r["engine"], r.get("engine_version")) if v) for r in mine if "engine" in r}
        assert c["engine"] == (", ".join(sorted(engines)) or "?")  # what the cell's trials ran on
        if not mine:
            assert c["success_rate"] is None and c["wilson95"] == [0.0, 1.0]
            continue
        assert c["success_rate"] == ok / len(mine)
        lo, hi = score_roots(ok, len(mine))
        assert c["wilson95"] == pytest.approx([lo, hi], abs=1e-9)
        assert c["wilson95"][0] <= c["success_rate"] <= c["wilson95"][1]
        for name in [*named, "sim_time", "wall_time"]:
            values = sorted(float(r["figures"][name]) if name in r["figures"] else float(r[name])
                            for r in mine if name in r["figures"] and plain_number(r["figures"][name])
                            or name not in r["figures"] and name in ("sim_time", "wall_time"))
            if not values:
                assert name not in c["figures"]
                continue
            got = c["figures"][name]
            mid = len(values) // 2
            median = values[mid] if len(values) % 2 else (values[mid - 1] + values[mid]) / 2
            rank = max(1, math.ceil(0.95 * len(values)))  # nearest rank: the smallest value with 95 % at or below
            assert (got["n"], got["median"], got["p95"]) == (len(values), pytest.approx(median), values[rank - 1])


@settings(PROPS, max_examples=15)
@given(sweeps())
def test_junit_markdown_and_failed_trials_list_every_row(tmp_path_factory: pytest.TempPathFactory,
                                                         sweep: tuple[list[dict[str, Any]], list[str]]) -> None:
    rows, cells = sweep
    path = tmp_path_factory.mktemp("junit") / "a" / "b" / "junit.xml"  # folders made as needed
    write_junit(rows, path)
    text = path.read_bytes()
    assert text.startswith(b"<?xml version='1.0' encoding='utf-8'?>")
    assert all(r["reason"].encode() in text for r in rows if r["outcome"] != "succeeded")  # UTF-8, not references
    assert ET.parse(path).getroot().tag == "testsuites"
    suite = ET.parse(path).getroot().find("testsuite")
    assert suite is not None
    cases = suite.findall("testcase")
    assert int(suite.get("tests", "-1")) == len(cases) == len(rows)
    assert int(suite.get("failures", "-1")) == len([r for r in rows if r["outcome"] in ("failed", "aborted")])
    assert int(suite.get("errors", "-1")) == len([r for r in rows if r["outcome"] == "error"])
    assert suite.get("name") == "robokit sweep"
    assert float(suite.get("time", "-1")) == pytest.approx(sum(r["wall_time"] for r in rows), abs=6e-4)
    for case, r in zip(cases, rows, strict=True):
        assert (case.get("classname"), case.get("name")) == (r["cell"], f"seed={r['seed']}")
        assert float(case.get("time", "-1")) == pytest.approx(r["wall_time"], abs=6e-4)
        assert case.findtext("system-out") == f"run_id={r['run_id']} worker={r['worker']}"
        failure, error = case.find("failure"), case.find("error")
        assert (failure is not None) == (r["outcome"] in ("failed", "aborted"))
        assert (error is not None) == (r["outcome"] == "error")
        if failure is not None:
            assert failure.get("message") == f"{r['outcome']}: {r['reason']}"
        if error is not None:
            assert error.get("message") == r["reason"]
    failed = failed_trials(rows, "configs/my robot.toml")
    assert [f["key"] for f in failed] == [r["key"] for r in rows if r["outcome"] != "succeeded"]
    for f, r in zip(failed, [r for r in rows if r["outcome"] != "succeeded"], strict=True):  # every field its row's
        assert f == {"key": r["key"], "cell": r["cell"], "seed": r["seed"], "outcome": r["outcome"],
                     "reason": r["reason"], "command": f["command"], "record": r.get("record")}
    for f in failed:
        r = next(r for r in rows if r["key"] == f["key"])
        argv = shlex.split(f["command"])
        assert argv[:5] == ["robokit", "run", "configs/my robot.toml", "--seed", str(r["seed"])]
        sets = dict(a.split("=", 1) for a in argv[6::2])
        assert argv[5::2] == ["--set"] * len(r["overrides"])
        assert {k: float(v) for k, v in sets.items()} == r["overrides"]
    summary = summarise(rows, cells)
    summary["failed_trials"] = failed
    table = to_markdown(summary).splitlines()
    head = [x.strip() for x in table[0].strip("|").split("|")]  # columns found by their names
    for c in summary["cells"]:
        line = next(x for x in table if x.startswith(f"| `{c['cell']}` |"))
        cols = dict(zip(head, [x.strip() for x in line.strip("|").split("|")], strict=True))
        assert cols["trials"] == str(c["trials"]) and cols["errors"] == str(c["errors"])
        rate = "-" if c["success_rate"] is None else f"{100 * c['success_rate']:.1f} %"
        assert cols["success"] == rate
        lo, hi = (100 * v for v in c["wilson95"])
        assert cols["95 % CI"] == f"{lo:.1f}–{hi:.1f} %" and cols["engine"] == c["engine"]
        for name in [*summary["metrics"], "sim_time"]:  # median / p95 of the cell's rows, at four digits
            values = sorted(float(r["figures"].get(name, r.get(name))) for r in rows if r["cell"] == c["cell"]
                            and plain_number(r["figures"].get(name, r.get(name))))
            want = "-" if not values else (f"{float(np.median(values)):.4g} / "
                                           f"{values[max(1, math.ceil(0.95 * len(values))) - 1]:.4g}")
            assert cols[f"{name} (median / p95)"] == want
    totals = f"{len(rows)} trials, {summary['succeeded']} succeeded, {summary['errors']} errors"
    assert any(x.startswith(totals) for x in table)
    lo, hi = (100 * v for v in score_roots(summary["succeeded"], len(rows))) if rows else (0.0, 100.0)
    assert f"{totals} (success 95 % CI {lo:.1f}–{hi:.1f} %)." in table
    assert_failed_listed(table, rows)


def assert_failed_listed(table: list[str], rows: list[dict[str, Any]]) -> None:
    """The Markdown's footer: the first 50 trials that did not succeed, each with its outcome, reason, reproduce
    command and kept record, then how many more there are."""
    failed = [r for r in rows if r["outcome"] != "succeeded"]
    start = [i for i, x in enumerate(table) if x.startswith("Trials that did not succeed")]
    if not failed:
        assert start == [] and not any(x.startswith(("- ", "  reproduce")) for x in table)
        return
    assert table[start[0]] == f"Trials that did not succeed ({len(failed)}):"
    listed = table[start[0] + 2:]
    for k, r in enumerate(failed[:50]):
        head, command = listed[2 * k], listed[2 * k + 1]
        assert head == f"- `{r['key']}`: {r['outcome']}: {r['reason'] or '(no reason given)'}"
        cmd, _, record = command.removeprefix("  reproduce: `").partition("`")
        argv = shlex.split(cmd)
        assert argv[:5] == ["robokit", "run", "configs/my robot.toml", "--seed", str(r["seed"])]
        assert record == (f"; record: {r['record']}" if r.get("record") else "")
    more = listed[2 * min(len(failed), 50):]
    assert more == ([f"- ... and {len(failed) - 50} more (every one is in summary.json)"] if len(failed) > 50 else [])


@settings(PROPS, max_examples=8)
@given(st.integers(45, 60), st.integers(0, 5))
def test_the_markdown_lists_fifty_failed_trials_and_counts_the_rest(failed: int, passed: int) -> None:
    rows = [{"key": f"base/{i}", "cell": "base", "seed": i, "overrides": {}, "reason": "" if i % 3 else "fell",
             "outcome": "succeeded" if i < passed else ("failed", "aborted", "error")[i % 3], "figures": {},
             "run_id": f"r{i}", "sim_time": 1.0, "wall_time": 0.1, **({"record": f"rec/{i}"} if i % 2 else {})}
            for i in range(failed + passed)]
    summary = summarise(rows, ["base"])
    summary["failed_trials"] = failed_trials(rows, "configs/my robot.toml")
    assert_failed_listed(to_markdown(summary).splitlines(), rows)


toml_values = st.recursive(
    st.one_of(st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=False, allow_infinity=False),
              st.text(max_size=6)),
    lambda inner: st.one_of(st.lists(inner, max_size=3),
                            st.dictionaries(st.text("abc_", min_size=1, max_size=3), inner, max_size=3)),
    max_leaves=6)


@settings(PROPS, max_examples=100)
@given(toml_values, st.sampled_from(["world.seed", "bodies.box.mass", "behaviour.goal"]))
def test_a_reproduce_command_sets_every_override_back_to_its_value(value: Any, key: str) -> None:
    """``--set KEY=VALUE`` in a failed trial's command reads back, through the command line's own ``--set`` reader,
    to the very value the trial ran with (text of any script included)."""
    from robokit.sweep.spec import parse_set
    from robokit.sweep.summary import reproduce_command

    argv = shlex.split(reproduce_command("c.toml", 3, {key: value}))
    assert argv[:5] == ["robokit", "run", "c.toml", "--seed", "3"] and argv[5] == "--set" and len(argv) == 7
    assert parse_set([argv[6]]) == ({}, {key: value})


# ------------------------------------------------------------------------------------------ a record's state stays
@st.composite
def traces(draw: Any) -> tuple[dict[str, Any], list[dict[str, Any]], float]:
    machines = draw(st.lists(st.sampled_from(["sort", "pick", "drive"]), min_size=1, max_size=3, unique=True))
    states = ["IDLE", "MOVE", "GRASP", "DONE"]
    initial = {m: draw(st.sampled_from(states)) for m in machines}
    current = dict(initial)
    events, t = [], 0.0
    for _ in range(draw(st.integers(0, 12))):
        t += draw(st.sampled_from([0.0, 1 / 240, 0.25, 1.5]))
        m = draw(st.sampled_from(machines))
        dest = draw(st.sampled_from(states))
        events.append({"kind": "transition", "t": t, "machine": m, "source_state": current[m], "dest_state": dest,
                       "trigger": f"to_{dest.lower()}"})
        current[m] = dest
        if draw(st.booleans()):
            events.append({"kind": "reading", "t": t, "sensor": "cam"})  # other records in between
    end = t + draw(st.sampled_from([0.0, 0.5, 3.0]))
    events.append({"kind": "end", "t": end})
    header = {"kind": "header", "schema": "robokit.record/1", "machines": [
        {"name": m, "initial": initial[m]} for m in machines]}
    return header, events, end


@PROPS
@given(traces())
def test_state_stays_and_state_changes_follow_the_transition_records(
        tmp_path_factory: pytest.TempPathFactory, trace: tuple[dict[str, Any], list[dict[str, Any]], float]) -> None:
    header, events, end = trace
    folder = tmp_path_factory.mktemp("run")
    (folder / TRACE_FILE).write_text("\n".join(json.dumps(x) for x in [header, *events]) + "\n", encoding="utf-8")
    rec = RunRecord(folder)
    spans = rec.spans()
    transitions = [e for e in events if e["kind"] == "transition"]
    for m in header["machines"]:
        name = m["name"]
        mine = [e for e in transitions if e["machine"] == name]
        stays = spans[name]
        # one stay per transition, plus the last; each begins where the previous ended, from 0 to the run's end
        assert len(stays) == len(mine) + 1
        assert [s.state for s in stays] == [m["initial"], *[e["dest_state"] for e in mine]]
        assert [s.start for s in stays] == [0.0, *[e["t"] for e in mine]]
        assert [s.end for s in stays] == [*[e["t"] for e in mine], end]
        for e in mine:  # the state a machine is in just after its transition
            assert rec.state_at(spans, e["t"])[name] == e["dest_state"] or any(
                x["t"] == e["t"] for x in mine if x is not e)  # several in the same instant: the last counts
    changes = state_changes(rec)
    assert len(changes) == len(header["machines"]) + len(transitions)
    assert [(t, m) for t, m, _ in changes[len(header["machines"]):]] == [(e["t"], e["machine"]) for e in transitions]
    for (_, _, text), e in zip(changes[len(header["machines"]):], transitions, strict=True):
        assert text == f"{e['machine']}: {e['source_state']} -> {e['dest_state']} ({e['trigger']})"


figures = st.dictionaries(
    st.sampled_from(["placed", "error_mm", "grade", "ok", "note", "<b>"]),
    st.one_of(st.integers(-5, 50), st.floats(-10, 10, allow_nan=False), st.booleans(), st.none(),
              st.sampled_from(["a & b", "시간"]), st.lists(st.integers(), max_size=2)), max_size=5)


@settings(PROPS, max_examples=30)
@given(traces(), figures)
def test_the_run_pages_seconds_per_state_and_figures_are_the_records(
        tmp_path_factory: pytest.TempPathFactory, trace: tuple[dict[str, Any], list[dict[str, Any]], float],
        result: dict[str, Any]) -> None:
    """``robokit view``'s page: each machine's diagram fills the states the run visited with the sim seconds spent
    there (a walk of the transitions from the initial state to the run's end, added up per state), leaves the others
    blank; the headline table lists every scalar figure of the result, in order, as text."""
    header, events, end = trace
    for m in header["machines"]:
        m.update(type="Machine", states=["IDLE", "MOVE", "GRASP", "DONE"],
                 transitions=[{"trigger": f"to_{d.lower()}", "source": "IDLE", "dest": d} for d in ("MOVE", "DONE")])
    folder = tmp_path_factory.mktemp("run")
    (folder / TRACE_FILE).write_text("\n".join(json.dumps(x) for x in [header, *events]) + "\n", encoding="utf-8")
    (folder / "result.json").write_text(json.dumps({"outcome": "succeeded", "sim_time": end, "result": result}),
                                        encoding="utf-8")
    page = build_page(RunRecord(folder), None, [])
    for m in header["machines"]:
        spent: dict[str, float] = {}
        state, since = m["initial"], 0.0
        for e in events:
            if e["kind"] == "transition" and e["machine"] == m["name"]:
                spent[state] = spent.get(state, 0.0) + e["t"] - since
                state, since = e["dest_state"], e["t"]
        spent[state] = spent.get(state, 0.0) + end - since
        svg = page[page.index(f"<h3>{m['name']} (Machine)</h3>"):]
        svg = svg[:svg.index("</svg>")]
        boxes = re.findall(r'<g class="state( visited)?">.*?font-weight="bold">(.*?)</text>.*?fill="#555">(.*?)</text>'
                           r"</g>", svg)
        assert sorted(b[1] for b in boxes) == sorted(m["states"])
        for visited, name, text in boxes:
            assert (visited == " visited") == (name in spent)
            assert text == (f"{spent[name]:.2f} s" if name in spent else "")
    table = page[page.index("<table class='figs'>"):]
    rows = re.findall(r"<tr><td>(.*?)</td><td class='num'>(.*?)</td></tr>", table[:table.index("</table>")])
    assert [(html.unescape(k), html.unescape(v)) for k, v in rows] == [
        (k, str(v)) for k, v in result.items() if not isinstance(v, list)]


# ------------------------------------------------------------------------------------------ a real sweep
@pytest.mark.slow  # eight trials in a worker process: ~3 s of CPU
def test_a_real_sweeps_summary_junit_and_records_agree_with_its_trial_rows(tmp_path: Path, monkeypatch: Any) -> None:
    """Two cells (one that succeeds, one that runs out of time) x four seeds, one of which raises: every figure
    of summary.json, every JUnit case and every kept record's outcome recomputed from trials.jsonl, and every row's
    figure from its own seed (the test behaviour's ``seed_squared``)."""
    from robokit.cli import main
    from robokit.sweep.summary import wilson

    plugins = Path(__file__).resolve().parent / "sweep_plugins"
    monkeypatch.syspath_prepend(str(plugins))
    monkeypatch.chdir(tmp_path)
    code = main(["sweep", str(plugins / "fault.toml"), "--plugin", "sweep_faults", "--seeds", "0:4", "--workers",
                 "1", "--set", "behaviour.duration=0.2,2.0", "--set", "behaviour.raise_seeds=[2]", "--out", "out",
                 "--junit", "junit.xml", "--keep", "all", "--quiet"])
    assert code in (0, 1)
    rows = [json.loads(x) for x in (tmp_path / "out" / "trials.jsonl").read_text().splitlines() if x.strip()]
    rows = [r for r in rows if "outcome" in r]
    assert len(rows) == 8 and {r["seed"] for r in rows} == {0, 1, 2, 3}
    for r in rows:
        long = r["overrides"]["behaviour.duration"] == 2.0
        assert r["outcome"] == ("error" if r["seed"] == 2 else "aborted" if long else "succeeded"), r
        assert r["figures"]["seed_squared"] == r["seed"] ** 2  # the figures it had when it ended, error or not
        if r.get("record"):
            kept = json.loads((Path(r["record"]) / "result.json").read_text())
            assert (kept["outcome"], kept["seed"]) == (r["outcome"], r["seed"])
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert (summary["trials"], summary["succeeded"], summary["errors"]) == (8, 3, 2)
    for c in summary["cells"]:
        mine = [r for r in rows if r["cell"] == c["cell"]]
        ok = sum(r["outcome"] == "succeeded" for r in mine)
        assert (c["trials"], c["succeeded"], c["success_rate"]) == (len(mine), ok, ok / len(mine))
        assert c["wilson95"] == pytest.approx(list(score_roots(ok, len(mine))), abs=1e-9)
        assert c["wilson95"] == pytest.approx(list(wilson(ok, len(mine))))
        squares = sorted(r["seed"] ** 2 for r in mine)  # docs/sweeps.md: each figure over the cell's rows
        assert c["figures"]["seed_squared"]["median"] == pytest.approx(float(np.median(squares)))
    suite = ET.parse(tmp_path / "junit.xml").getroot().find("testsuite")
    assert suite is not None
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("8", "3", "2")
