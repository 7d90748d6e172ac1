"""A sweep never crashes on its own summary: the Wilson bounds hold the rate inside [0, 1] for every n and k, and
the summary, table and JUnit are written even when a plot cannot be drawn."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from robokit.cli import main
from robokit.sweep.summary import error_bars, summarise, wilson, write_plots

ROOT = Path(__file__).resolve().parent.parent
PLUGINS = Path(__file__).resolve().parent / "sweep_plugins"


def _holds(k: int, n: int) -> None:
    lo, hi = wilson(k, n)
    rate = k / n
    assert 0.0 <= lo <= rate <= hi <= 1.0, (k, n, lo, hi)
    below, above = error_bars(100 * rate, 100 * lo, 100 * hi)
    assert below >= 0.0 and above >= 0.0


def test_every_n_up_to_1000_and_every_k_keeps_the_rate_inside_its_interval() -> None:
    """All 501,500 pairs (1 <= n <= 1000, 0 <= k <= n); wilson(10, 10) upper was 0.9999999999999999 before."""
    for n in range(1, 1001):
        for k in range(n + 1):
            _holds(k, n)
    assert wilson(10, 10)[1] == 1.0 and wilson(0, 10)[0] == 0.0


@given(st.integers(min_value=1, max_value=1000).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_wilson_property(pair: tuple[int, int]) -> None:
    """The same property stated for Hypothesis, with the textbook formula as the independent reference: away from
    the clamped ends the bounds are the formula's own to 1e-12."""
    k, n = pair
    _holds(k, n)
    z, p = 1.959963984540054, k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = wilson(k, n)
    if 0 < k < n:
        assert lo == pytest.approx(centre - half, abs=1e-12) and hi == pytest.approx(centre + half, abs=1e-12)


def rows(outcomes: list[str]) -> list[dict[str, Any]]:
    return [{"key": f"k{i}", "cell": "base", "overrides": {}, "seed": i, "run_id": f"r{i}", "outcome": o,
             "reason": "" if o == "succeeded" else "goal not met", "sim_time": 1.0, "wall_time": 0.1,
             "figures": {"score": float(i)}} for i, o in enumerate(outcomes)]


@pytest.mark.parametrize("outcomes", [["succeeded"] * 10, ["failed"] * 10, ["succeeded"] * 7 + ["failed"] * 3])
def test_plots_of_all_green_all_red_and_mixed_cells_are_drawn(outcomes: list[str], tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    trial_rows = rows(outcomes)
    written = write_plots(summarise(trial_rows, ["base"]), trial_rows, tmp_path)
    assert [p.name for p in written] == ["success_rate.png", "distribution_score.png"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in written)


@pytest.mark.slow  # ten drop_test trials: ~10 s on two loaded cores
def test_drop_test_sweep_of_ten_seeds_exits_0_with_the_table_and_junit(tmp_path: Path, monkeypatch: Any,
                                                                       capsys: Any) -> None:
    """``robokit sweep configs/drop_test.toml --seeds 0:10``: every trial succeeds (the all-green cell that crashed
    the plot) and the command exits 0 with its table, JUnit file and plots."""
    monkeypatch.chdir(tmp_path)
    junit = tmp_path / "junit.xml"
    code = main(["sweep", str(ROOT / "configs" / "drop_test.toml"), "--seeds", "0:10", "--workers", "2",
                 "--out", "out", "--junit", str(junit)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert re.search(r"\| `base` \| pybullet [\d.]+ \| 10 \| 100\.0 % \|", out)  # the engine that ran each cell
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite is not None and suite.get("tests") == "10" and suite.get("failures") == "0"
    assert len(suite.findall("testcase")) == 10
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["succeeded"] == 10 and summary["cells"][0]["wilson95"][1] == 1.0
    assert (tmp_path / "out" / "success_rate.png").is_file()


@pytest.mark.slow
def test_a_plot_that_fails_is_a_warning_and_the_rest_is_written(tmp_path: Path, monkeypatch: Any,
                                                                capsys: Any) -> None:
    def broken_plots(*_args: Any, **_kwargs: Any) -> list[Path]:
        raise ValueError("'yerr' must not contain negative values")

    monkeypatch.setattr("robokit.sweep.engine.write_plots", broken_plots)
    monkeypatch.syspath_prepend(str(PLUGINS))  # the cheap test-only scene (workers inherit sys.path)
    monkeypatch.chdir(tmp_path)
    junit = tmp_path / "junit.xml"
    code = main(["sweep", str(PLUGINS / "fault.toml"), "--plugin", "sweep_faults", "--seeds", "0:2", "--workers",
                 "1", "--out", "out", "--junit", str(junit)])
    captured = capsys.readouterr()
    assert code == 0
    assert "robokit: warning: sweep: the plots in out could not be drawn: ValueError: 'yerr' must not contain " \
           "negative values; the summary, table and JUnit file are written" in captured.err
    assert re.search(r"\| `base` \| pybullet [\d.]+ \| 2 \| 100\.0 % \|", captured.out)
    assert junit.is_file() and (tmp_path / "out" / "summary.md").is_file()
