"""Sweep outputs against their sources: every JUnit count against the cases it holds and the rows they came from,
a torn ``trials.jsonl`` against the whole lines written before the tear, and the records a sweep keeps against
the outcomes of its trials."""

from __future__ import annotations

import json
import uuid
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.sweep.engine import read_trials
from robokit.sweep.summary import write_junit
from robokit.sweep.trial import TrialTask, run_trial, trial_run_id

OUTCOMES = ("succeeded", "failed", "aborted", "error")

row_st = st.fixed_dictionaries({
    "outcome": st.sampled_from(OUTCOMES),
    "seed": st.integers(0, 99),
    "cell": st.sampled_from(["base", "behaviour.speed=0.6", "behaviour.speed=1.2"]),
    "reason": st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=20),
    "wall_time": st.floats(0, 50, allow_nan=False),
})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(row_st, max_size=12))
def test_junit_counts_are_the_cases_it_holds(tmp_path: Path, rows: list[dict]) -> None:
    rows = [{**r, "run_id": f"r{i}", "key": f"{r['cell']}/seed={r['seed']}"} for i, r in enumerate(rows)]
    path = tmp_path / "junit.xml"
    write_junit(rows, path)
    suite = ET.parse(path).getroot().find("testsuite")
    assert suite is not None
    cases = suite.findall("testcase")
    failures = [c for c in cases if c.find("failure") is not None]
    errors = [c for c in cases if c.find("error") is not None]
    # the suite's attributes say what its cases say ...
    assert int(suite.get("tests")) == len(cases) == len(rows)
    assert int(suite.get("failures")) == len(failures)
    assert int(suite.get("errors")) == len(errors)
    # ... and the cases say what the rows say: every trial that did not succeed is a failure or an error
    assert len(failures) == sum(r["outcome"] in ("failed", "aborted") for r in rows)
    assert len(errors) == sum(r["outcome"] == "error" for r in rows)
    assert abs(float(suite.get("time")) - sum(float(f"{r['wall_time']:.3f}") for r in rows)) < 1e-3 * (len(rows) + 1)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.integers(0, 10**6), min_size=1, max_size=6), st.data())
def test_a_torn_trials_file_keeps_every_whole_line_and_takes_more(tmp_path: Path, seeds: list[int],
                                                                  data: st.DataObject) -> None:
    path = tmp_path / f"{uuid.uuid4().hex}.jsonl"
    lines = [json.dumps({"key": f"base/seed={s}-{i}", "seed": s, "outcome": "succeeded"}, separators=(",", ":"))
             for i, s in enumerate(seeds)]
    whole = "".join(line + "\n" for line in lines).encode()
    cut = data.draw(st.integers(0, len(whole) - 1), label="the process died after this many bytes")
    path.write_bytes(whole[:cut])
    kept = whole[:cut][: whole[:cut].rfind(b"\n") + 1]  # the oracle: every line written in full
    rows = read_trials(path)
    assert path.read_bytes() == kept
    assert list(rows) == [json.loads(line)["key"] for line in kept.decode().splitlines()]
    with open(path, "a", encoding="utf-8") as fh:  # the sweep goes on: a row appended as the engine appends one
        fh.write(json.dumps({"key": "base/seed=next", "outcome": "failed"}, separators=(",", ":")) + "\n")
    again = read_trials(path)
    assert list(again) == [*rows, "base/seed=next"]


DROP = """
[world]
max_time = {max_time}
[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]
[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
mass = 1.0
position = [0, 0, 0.3]
[sensors.poses]
type = "body_pose"
bodies = ["box"]
[behaviour]
type = "drop_test"
duration = 0.05
"""


@pytest.mark.parametrize("max_time, outcome", [(0.02, "aborted"), (0.2, "succeeded")])
def test_keep_failed_keeps_the_record_of_every_trial_that_did_not_succeed(tmp_path: Path, max_time: float,
                                                                           outcome: str) -> None:
    """An aborted trial (max_time before the behaviour ends) keeps its record; a succeeded one does not."""
    text = DROP.format(max_time=max_time)
    sweep_id = str(uuid.uuid4())
    task = TrialTask("base/seed=0", "base", {}, 0, trial_run_id(sweep_id, "base/seed=0"), text, "drop.toml",
                     str(tmp_path), keep="failed", record_dir=str(tmp_path / "runs"))
    row = run_trial(task)
    folder = tmp_path / "runs" / task.run_id
    assert row["outcome"] == outcome
    if row["outcome"] == "succeeded":
        assert "record" not in row and not folder.exists()
    else:
        assert row.get("record") == str(folder)
        kept = json.loads((folder / "result.json").read_text(encoding="utf-8"))
        assert kept["outcome"] == row["outcome"] and kept["run_id"] == task.run_id
