"""Error runs keep their trace: the records up to the error, then the error itself (also when setup fails)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from plugin_dists import FAULTY_SENSORS, make_dist

from robokit.cli import main

SCENE = '[world]\nmax_time = 1.0\n[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'


@pytest.fixture
def faulty(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    make_dist(tmp_path / "dists", "fault-dist", "1.0", FAULTY_SENSORS)
    monkeypatch.syspath_prepend(str(tmp_path / "dists"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def run(folder: Path, config: str) -> tuple[int, list[dict[str, Any]]]:
    path, trace = folder / "c.toml", folder / "trace.jsonl"
    path.write_text(SCENE + config)
    code = main(["run", str(path), "--trace", str(trace), "--quiet"])
    return code, [json.loads(line) for line in trace.read_text().splitlines()]


def test_a_plugin_error_mid_run_leaves_the_records_before_it_and_the_error_last(faulty: Path) -> None:
    code, records = run(faulty, '[sensors.s]\ntype = "flaky_read"\nfail_at_read = 20\n'
                                '[behaviour]\ntype = "record"\nduration = 1.0\n')
    assert code == 3
    readings = [r for r in records if r["kind"] == "reading"]
    assert [r["value"] for r in readings] == [float(i) for i in range(1, 20)]  # every read before the 20th
    last = records[-1]
    assert (last["kind"], last["source"], last["tick"]) == ("error", "run", 19)
    assert last["reason"].startswith("sensor 's' (type 'flaky_read' from fault-dist 1.0) raised during read: "
                                     "RuntimeError: sensor bus timeout")


def test_a_setup_error_leaves_a_trace_with_the_error(faulty: Path) -> None:
    code, records = run(faulty, '[sensors.s]\ntype = "flaky_setup"\n[behaviour]\ntype = "record"\n')
    assert code == 3
    assert len(records) == 1 and records[0]["kind"] == "error"
    assert "sensor type 'flaky_setup' (fault-dist 1.0) raised during setup: RuntimeError: calibration file missing" \
        in records[0]["reason"]


def test_records_written_during_setup_reach_the_trace_file(faulty: Path) -> None:
    code, records = run(faulty, '[sensors.s]\ntype = "flaky_read"\nfail_at_read = 1000\n'
                                '[behaviour]\ntype = "sequence"\n[[behaviour.steps]]\ntype = "record"\n'
                                'duration = 0.01\n[[behaviour.steps]]\ntype = "record"\nduration = 0.01\n')
    assert code == 0
    marks = [(r["kind"], r["step"]) for r in records if r["kind"].startswith("step_")]
    assert marks[0] == ("step_start", "record_1")  # written in setup, before the first tick
    assert marks[-1] == ("step_end", "record_2")
