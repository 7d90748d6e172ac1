"""``robokit validate`` agrees with the run on reach: a corpus of bin layouts of the main job, each validated once
(as a user would, at the config's seed) and run on ten seeds. No layout validate refuses sorts 8 or more of 10;
none it passes fails 5 or more of 10 because something was out of reach.

Validate plans the moves the run will make (look position; above each object, down, up, across to its bin's slot,
down, up) with the arm's own path solver, waypoints and tolerances (see ``behaviours/sort_reach.py``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from robokit.sweep import SweepOptions, SweepSpec, run_sweep
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
SORT = ROOT / "configs" / "sort_robot.toml"
RED = [(0.35, 0.42), (0.62, 0.45), (0.68, 0.43), (0.72, 0.42), (0.02, 0.7)]  # near, far, near the edge, beyond it
BLUE = [(0.35, -0.42), (0.66, -0.45), (0.70, -0.42), (0.15, -0.65)]
SEEDS = range(10)


def layout_key(red: tuple[float, float], blue: tuple[float, float]) -> dict[str, Any]:
    return {"bodies.red_bin.position": [red[0], red[1], 0.0], "bodies.blue_bin.position": [blue[0], blue[1], 0.0]}


def validate_reach(overrides: dict[str, Any]) -> list[str]:
    """What validate says about reach for this layout (its other checks are not the subject here)."""
    with make_sim(SORT, overrides=overrides) as sim:
        return [str(p) for p in sim.preflight() if "reach" in str(p)]


@pytest.mark.slow  # 200 runs of the main job: several minutes on two cores
@pytest.mark.timeout(3600)
def test_validate_and_the_runs_agree_on_reach(tmp_path: Path) -> None:
    grid = {"bodies.red_bin.position": tuple([x, y, 0.0] for x, y in RED),
            "bodies.blue_bin.position": tuple([x, y, 0.0] for x, y in BLUE)}
    run = run_sweep(SweepSpec(SORT, SEEDS, grid), SweepOptions(out=tmp_path / "out", workers=2, keep="none"))
    assert run.remaining == 0
    disagreements, table = [], []
    for red in RED:
        for blue in BLUE:
            overrides = layout_key(red, blue)
            refused = validate_reach(overrides)
            rows = [r for r in run.rows if r["overrides"] == json.loads(json.dumps(overrides))]
            assert len(rows) == len(SEEDS)
            sorted_ok = sum(r["outcome"] == "succeeded" for r in rows)
            reach_failures = sum(r["outcome"] != "succeeded" and "unreachable" in r["reason"] for r in rows)
            table.append(f"red {red} blue {blue}: validate {'refuses' if refused else 'passes'}, sorted "
                         f"{sorted_ok}/10, failed for reach {reach_failures}/10")
            if refused and sorted_ok >= 8:
                disagreements.append(f"{table[-1]}: {refused[0][:200]}")
            if not refused and reach_failures >= 5:
                disagreements.append(table[-1])
    print("\n" + "\n".join(table))
    assert not disagreements, "\n".join(disagreements)
