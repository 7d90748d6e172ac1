"""A sweep run in several invocations (``--max-trials``, then resumed) against a plain tally of its trials.

docs/sweeps.md promises: a sweep skips the trials already in ``trials.jsonl`` and runs the rest in the sweep's
order; the summary counts every finished trial, earlier invocations included; each cell's success rate is the share
of its trials that succeeded (the mean of the per-trial flags), its errors those that raised; ``failed_trials`` lists
every trial that did not succeed; the progress line counts done trials and those not succeeded, the resumed ones
included; the sweep has succeeded only when every trial ran and succeeded (the command's exit code).

The trials are real runs of the test-only ``fault`` behaviour, whose outcome the test knows beforehand: it raises on
its raise seeds, succeeds after ``duration`` sim seconds, and is aborted when that is past ``world.max_time``. The
trials run in the test's process (the worker pool's processes cost seconds to start): each is the same
``run_trial_safely`` call a worker makes.
"""

from __future__ import annotations

import io
import json
import shlex
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.sweep import engine
from robokit.sweep.engine import SweepOptions, run_sweep
from robokit.sweep.spec import SweepSpec
from robokit.sweep.summary import to_markdown
from robokit.sweep.trial import run_trial_safely

PLUGINS = Path(__file__).resolve().parent / "sweep_plugins"
MAX_TIME = 0.04
FIELDS = {"key", "cell", "overrides", "seed", "run_id", "outcome", "reason", "figures", "sim_time", "ticks",
          "wall_time", "run_wall_time", "worker", "engine", "engine_version"}


def in_process(spec: Any, opts: Any) -> Any:
    return lambda tasks: (run_trial_safely(task) for task in tasks)


def expected(seed: int, duration: float, raise_seeds: list[int]) -> str:
    if seed in raise_seeds:
        return "error"
    return "succeeded" if duration <= MAX_TIME else "aborted"


def check(folder: Path, monkeypatch: pytest.MonkeyPatch, durations: list[float], seeds: int, raise_seeds: list[int],
          splits: list[int], plots: bool = True) -> None:
    monkeypatch.syspath_prepend(str(PLUGINS))
    monkeypatch.setattr(engine, "_backend", in_process)
    spec = SweepSpec(PLUGINS / "fault.toml", range(seeds), {"behaviour.duration": tuple(durations)},
                     {"behaviour.raise_seeds": raise_seeds, "behaviour.at": 0.01, "world.max_time": MAX_TIME},
                     metrics=("sim_time", "seed_squared"), plugins=("sweep_faults",))
    order = [(d, s) for d in durations for s in range(seeds)]  # cell by cell, seeds in order
    done = 0
    for n, limit in enumerate([*splits, None]):
        progress = io.StringIO()
        run = run_sweep(spec, SweepOptions(out=folder, max_trials=limit, keep="none", progress=progress,
                                           junit=folder / "junit.xml"))
        ran = len(order) - done if limit is None else min(limit, len(order) - done)
        before, done = done, done + ran
        finished = order[:done]
        flags = [expected(s, d, raise_seeds) for d, s in finished]
        # the rows: every trial finished so far, in the sweep's order, each with its own outcome
        assert [(r["overrides"]["behaviour.duration"], r["seed"]) for r in run.rows] == finished
        assert [r["outcome"] for r in run.rows] == flags
        for row, (duration, seed), flag in zip(run.rows, finished, flags, strict=True):
            assert row["key"] == f"behaviour.duration={duration}/seed={seed}"
            if flag == "error":
                continue
            assert row["figures"] == {"seed_squared": seed * seed}
            assert row["sim_time"] == pytest.approx(row["ticks"] / 240, abs=1e-6)
            end = duration if flag == "succeeded" else MAX_TIME
            assert end - 1e-9 <= row["sim_time"] <= end + 2 / 240, (row["sim_time"], end)
        assert (run.ran, run.skipped, run.remaining) == (ran, before, len(order) - done)
        assert run.all_succeeded == (done == len(order) and all(f == "succeeded" for f in flags))
        trials = folder / "trials.jsonl"
        on_disk = [json.loads(line) for line in trials.read_text().splitlines()] if trials.exists() else []
        for row in on_disk:  # the documented fields, the engine's, nothing of the worker's own
            assert set(row) <= FIELDS and set(row) >= FIELDS - {"run_wall_time", "engine", "engine_version"}, row
        assert run.out == folder and run.files[:3] == [folder / "summary.json", folder / "summary.md",
                                                       folder / "junit.xml"]
        assert (folder / "summary.md").read_text() == to_markdown(run.summary)
        if plots:  # the rate per cell, and the first metric's distribution once a trial has run (errors too)
            drawn = [folder / "success_rate.png"] + [folder / "distribution_sim_time.png"] * (done > 0)
            assert run.files[3:] == drawn and all(f.stat().st_size > 1000 for f in drawn)
        assert sorted((r["overrides"]["behaviour.duration"], r["seed"], r["outcome"]) for r in on_disk) == sorted(
            (d, s, f) for (d, s), f in zip(finished, flags, strict=True))
        # the summary: counts and rates recomputed from the per-trial flags
        summary = json.loads((folder / "summary.json").read_text())
        assert summary == json.loads(json.dumps(run.summary)) and summary["metrics"] == ["sim_time", "seed_squared"]
        assert (summary["trials"], summary["succeeded"], summary["errors"]) == (
            done, flags.count("succeeded"), flags.count("error"))
        assert [c["cell"] for c in summary["cells"]] == [f"behaviour.duration={d}" for d in durations]
        for cell, duration in zip(summary["cells"], durations, strict=True):
            mine = [f for (d, _), f in zip(finished, flags, strict=True) if d == duration]
            assert (cell["trials"], cell["succeeded"], cell["errors"]) == (
                len(mine), mine.count("succeeded"), mine.count("error"))
            if mine:
                assert cell["success_rate"] == sum(f == "succeeded" for f in mine) / len(mine)
                assert cell["wilson95"][0] <= cell["success_rate"] <= cell["wilson95"][1]
                assert cell["overrides"] == {**spec.fixed, "behaviour.duration": duration}
            else:
                assert cell["success_rate"] is None
        for f in summary["failed_trials"]:  # each reproduced by its own command
            assert shlex.split(f["command"])[:5] == ["robokit", "run", str(spec.config), "--seed", str(f["seed"])]
        assert sorted((f["seed"], f["outcome"]) for f in summary["failed_trials"]) == sorted(
            (s, f) for (_, s), f in zip(finished, flags, strict=True) if f != "succeeded")
        junit = (folder / "junit.xml").read_text()
        assert junit.count("<testcase ") == done and junit.count("<failure ") == flags.count("aborted")
        assert junit.count("<error ") == flags.count("error")
        # the progress: resumed trials and their failures counted from the first line to the last
        lines = progress.getvalue().splitlines()
        if before:
            assert lines[0] == f"sweep: {before}/{len(order)} trials already done, resuming"
        if ran:
            bad = len(flags) - flags.count("succeeded")
            assert lines[-1].startswith(f"sweep: {done}/{len(order)} done, {bad} not succeeded"), (n, lines)
    assert done == len(order)


@pytest.mark.slow  # a few short real trials per example, ~0.5 s
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from([0.02, 0.03, 0.06, 0.1]), min_size=1, max_size=3, unique=True),
       st.integers(1, 3), st.lists(st.integers(0, 2), max_size=2, unique=True),
       st.lists(st.integers(0, 4), max_size=3))
def test_a_resumed_sweep_counts_every_trial_as_a_plain_tally_does(
        tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch, durations: list[float],
        seeds: int, raise_seeds: list[int], splits: list[int]) -> None:
    check(tmp_path_factory.mktemp("sweep"), monkeypatch, durations, seeds, raise_seeds, splits)


def test_a_sweep_resumed_after_an_error_and_an_abort(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two cells of three seeds; seed 2 raises; the second cell runs past its time. Two trials that succeeded
    first (not yet a sweep that succeeded), the error, none, then the other three.
    The PNG plots are left out here (matplotlib's drawing is most of this test's time; the property above and
    test_sweep.py draw them)."""
    monkeypatch.setattr(engine, "write_plots", lambda *args, **kwargs: [])
    check(tmp_path, monkeypatch, [0.02, 0.06], 3, [2], [2, 1, 0], plots=False)
