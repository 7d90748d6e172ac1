"""The issue's end-to-end sweeps on the local backend (slow): a 2x3 grid x 4 seeds of pick_place, and the same sweep
interrupted by a real SIGINT and resumed, giving exactly the trials of the uninterrupted one. (The Ray backend on a
real two-node cluster is tested against the same sweep in test_sweep_ray.py.)"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
from test_sweep import PICK, stable

from robokit.sweep import SweepOptions, SweepRun, SweepSpec, parse_set, read_trials, run_sweep

pytestmark = pytest.mark.slow

GRID = ["behaviour.speed=0.8,1.2", "behaviour.slow_speed=0.3,0.45,0.6"]


def pick_spec() -> SweepSpec:
    grid, fixed = parse_set(GRID)
    return SweepSpec(PICK, range(4), grid, fixed, metrics=("attempts", "placement_error", "sim_time"))


@pytest.fixture(scope="module")
def local_run(tmp_path_factory: pytest.TempPathFactory) -> SweepRun:
    """The uninterrupted 2x3x4 sweep on the local backend (two spawn workers)."""
    return run_sweep(pick_spec(), SweepOptions(out=tmp_path_factory.mktemp("local") / "out", workers=2))


def test_a_2x3_grid_of_pick_place_times_4_seeds_runs_locally(local_run: SweepRun) -> None:
    assert len(local_run.rows) == 24 and local_run.remaining == 0
    assert [c["trials"] for c in local_run.summary["cells"]] == [4] * 6
    assert all(r["outcome"] == "succeeded" for r in local_run.rows), [r["reason"] for r in local_run.rows]
    assert all(r["figures"]["placement_error"] < 0.02 for r in local_run.rows)
    speeds = {(r["overrides"]["behaviour.speed"], r["overrides"]["behaviour.slow_speed"]) for r in local_run.rows}
    assert len(speeds) == 6
    slow = [r["sim_time"] for r in local_run.rows if r["overrides"]["behaviour.slow_speed"] == 0.3]
    quick = [r["sim_time"] for r in local_run.rows if r["overrides"]["behaviour.slow_speed"] == 0.6]
    assert sum(slow) > sum(quick)  # the override reached the behaviour: slower approach, longer runs
    assert len({r["worker"] for r in local_run.rows}) >= 2


def test_interrupted_by_sigint_and_resumed_gives_exactly_the_uninterrupted_trials(
        local_run: SweepRun, tmp_path: Path) -> None:
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "robokit.cli", "sweep", str(PICK), "--seeds", "0:4", *sum((["--set", s] for s in GRID),
           []), "--metrics", "attempts,placement_error,sim_time", "--workers", "2", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:  # plain progress: one line per finished trial (stdout is a pipe)
        if line.startswith("sweep: 5/24 done"):
            proc.send_signal(signal.SIGINT)
            break
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    kept = read_trials(out / "trials.jsonl")
    assert 5 <= len(kept) < 24, len(kept)
    assert "re-run the same command to resume" in err
    resumed = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert f"ran {24 - len(kept)}, {len(kept)} already done" in resumed.stdout
    rows = list(read_trials(out / "trials.jsonl").values())
    assert len(rows) == 24
    assert sorted(stable(rows), key=lambda r: r["key"]) == sorted(stable(local_run.rows), key=lambda r: r["key"])
