"""Sweep promises with independent expectations: the Wilson interval solves its defining equation and stays in
[0, 1] (Hypothesis), the nearest-rank percentile by its definition, seed ranges A:B (Hypothesis), error and JUnit
failure counts, the success-rate plot judged by its pixels, a dead worker's trial run exactly twice, a hanging trial
timed out whatever the machine's speed."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import UserError
from robokit.sweep import SweepOptions, SweepSpec, parse_seeds, run_sweep
from robokit.sweep.summary import percentile, summarise, wilson, write_junit, write_plots

HERE = Path(__file__).resolve().parent
FAULT = HERE / "sweep_plugins" / "fault.toml"
Z = 1.959963984540054


# ------------------------------------------------------------------ statistics
@settings(max_examples=400, deadline=None)
@given(n=st.integers(1, 2000), data=st.data())
def test_wilson_bounds_solve_the_score_equation_and_stay_in_0_1(n: int, data: st.DataObject) -> None:
    """Each bound pi satisfies (p - pi)^2 = z^2 pi (1 - pi) / n (the score test at its edge), lo <= p <= hi."""
    k = data.draw(st.integers(0, n))
    lo, hi = wilson(k, n)
    p = k / n
    assert 0.0 <= lo and hi <= 1.0  # never outside [0, 1] (unclamped, k = 0 of n = 21 gives a negative lo)
    assert lo <= p + 1e-12 and p <= hi + 1e-12
    for bound in (lo, hi):
        if 0.0 < bound < 1.0:
            assert (p - bound) ** 2 == pytest.approx(Z * Z * bound * (1 - bound) / n, rel=1e-6, abs=1e-12)
    if k == 0:
        assert lo == pytest.approx(0.0, abs=1e-12)
    if k == n:
        assert hi == 1.0 or hi == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize(("k", "n", "lo", "hi"), [(5, 10, 0.2366, 0.7634), (0, 10, 0.0, 0.2775),
                                                   (9, 10, 0.5958, 0.9821)])
def test_wilson_known_values(k: int, n: int, lo: float, hi: float) -> None:
    assert wilson(k, n) == pytest.approx((lo, hi), abs=1e-4)


@settings(max_examples=300, deadline=None)
@given(values=st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=60), q=st.floats(0.5, 100.0))
def test_percentile_is_the_smallest_value_with_at_least_q_percent_at_or_below_it(values: list[float],
                                                                                 q: float) -> None:
    ordered = sorted(values)
    want = next(x for x in ordered if sum(v <= x for v in ordered) / len(ordered) >= q / 100.0 - 1e-12)
    assert percentile(values, q) == want


def test_p95_of_20_values_is_the_19th_smallest() -> None:
    assert percentile(list(range(1, 21)), 95) == 19


@settings(max_examples=200, deadline=None)
@given(a=st.integers(0, 10_000), width=st.integers(1, 500))
def test_seeds_a_colon_b_are_a_to_b_minus_1(a: int, width: int) -> None:
    assert list(parse_seeds(f"{a}:{a + width}")) == list(range(a, a + width))
    assert list(parse_seeds(str(a))) == [a]


@pytest.mark.parametrize("text", ["4:4", "5:3", "-1:2", "x", "1:2:3"])
def test_empty_or_malformed_seed_ranges_are_refused(text: str) -> None:
    with pytest.raises(UserError):
        parse_seeds(text)


def row(cell: str, seed: int, outcome: str) -> dict[str, Any]:
    return {"key": f"{cell}/seed={seed}", "cell": cell, "overrides": {}, "seed": seed, "outcome": outcome,
            "reason": "why" if outcome != "succeeded" else "", "figures": {"x": seed}, "sim_time": 1.0,
            "wall_time": 0.5, "run_id": f"r{seed}", "worker": "w0"}


OUTCOMES = ["succeeded", "succeeded", "failed", "aborted", "error", "succeeded"]


def test_summary_counts_errors_and_junit_counts_failed_and_aborted(tmp_path: Path) -> None:
    rows = [row("a", i, o) for i, o in enumerate(OUTCOMES)]
    cell = summarise(rows, ["a"])["cells"][0]
    assert (cell["trials"], cell["succeeded"], cell["errors"]) == (6, 3, 1)
    assert cell["wilson95"] == pytest.approx(list(wilson(3, 6)))
    write_junit(rows, tmp_path / "junit.xml")
    suite = ET.parse(tmp_path / "junit.xml").getroot().find("testsuite")
    assert suite is not None
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors")) == ("6", "2", "1")


def bar_heights(png: Path) -> list[int]:
    """Heights (pixels) of the bars in the success-rate plot, left to right: the longest vertical run of the bar
    colour (#4c72b0) in each column, grouped into bars."""
    import matplotlib.image as mpimg

    img = mpimg.imread(str(png))[:, :, :3]
    blue = np.all(np.abs(img - np.array([0x4C, 0x72, 0xB0]) / 255.0) < 0.03, axis=2)
    counts = blue.sum(axis=0)
    bars, current = [], 0
    for c in counts:
        if c > 0:
            current = max(current, int(c))
        elif current:
            bars.append(current)
            current = 0
    return bars + ([current] if current else [])


def test_the_success_rate_plot_draws_each_cells_rate_to_scale(tmp_path: Path) -> None:
    """Cells at 100 % and 50 %: two bars, the first twice as tall and reaching most of the 0-105 % axis."""
    pytest.importorskip("matplotlib")
    rows = [row("full", i, "succeeded") for i in range(4)] + [row("half", i, o) for i, o in
                                                                enumerate(["succeeded", "failed"] * 2)]
    summary = summarise(rows, ["full", "half"])
    written = write_plots(summary, rows, tmp_path)
    assert tmp_path / "success_rate.png" in written
    full, half = bar_heights(tmp_path / "success_rate.png")
    assert full / half == pytest.approx(2.0, rel=0.05)
    assert full > 0.5 * 360  # the figure is 3.6 in at 100 dpi: a 100 % bar fills most of the axes


# ------------------------------------------------------------------ workers
class CountConfig(Schema):
    """Append a line to ``log`` whenever a trial starts; die (exit 17) on ``die_seeds``."""

    log: str
    die_seeds: list[int] = Field(default_factory=list)


class CountedFault(Behaviour):
    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        with open(self.config.log, "a", encoding="utf-8") as fh:
            fh.write(f"{ctx.world.seed}\n")
        if ctx.world.seed in self.config.die_seeds:
            os._exit(17)

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        if t >= 0.05:
            self.finish("succeeded", "ran")


@hookimpl
def robokit_register_behaviours(register: Any) -> None:
    register("counted_fault", CountedFault, CountConfig)


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_a_trial_whose_worker_dies_is_run_exactly_twice(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(HERE))  # spawned workers import this module as the plugin
    cfg = tmp_path / "count.toml"
    log = tmp_path / "starts.log"
    cfg.write_text(FAULT.read_text(encoding="utf-8").replace('type = "fault"', 'type = "counted_fault"'),
                   encoding="utf-8")
    spec = SweepSpec(cfg, range(3), fixed={"behaviour.log": str(log), "behaviour.die_seeds": [1]},
                     plugins=("test_pins_sweep",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=1))
    starts = log.read_text(encoding="utf-8").split()
    assert sorted(starts) == ["0", "1", "1", "2"]  # seed 1: the first try and one retry, no third
    by_seed = {r["seed"]: r for r in run.rows}
    assert by_seed[1]["outcome"] == "error" and "worker died twice" in by_seed[1]["reason"]
    assert by_seed[0]["outcome"] == by_seed[2]["outcome"] == "succeeded"


@pytest.mark.slow
def test_a_hanging_trial_times_out_whatever_the_machines_speed(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """The only trial hangs for ever: any --trial-timeout ends it, however slow the machine (no other trial
    has to finish within the budget)."""
    monkeypatch.syspath_prepend(str(HERE / "sweep_plugins"))
    spec = SweepSpec(FAULT, range(1), fixed={"behaviour.hang_seeds": [0]}, plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=1, trial_timeout=1.0))
    [only] = run.rows
    assert only["outcome"] == "error" and only["reason"].startswith("timed out: no result after 1 s")
    assert math.isfinite(only["wall_time"]) and only["wall_time"] >= 1.0
