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


# ---------------------------------------------------------------------------------------------- three colours
GREEN = [(0.7, 0.42), (0.72, 0.4), (0.74, 0.38), (0.75, 0.36), (0.76, 0.34), (0.77, 0.3), (0.78, 0.3), (0.8, 0.3),
         (0.77, 0.32), (0.66, 0.46), (0.68, 0.44), (0.6, 0.5), (0.45, 0.6), (0.3, 0.66), (0.2, 0.7), (0.0, 0.62),
         (-0.1, 0.6)]
"""Green bin positions (x, y, m) across the edge of the Panda's reach, beside the main job's red and blue bins."""


def three_colours(green: tuple[float, float]) -> dict[str, Any]:
    """The main job with two green cubes and a green bin at ``green``, as an outside author writes it."""
    from robokit.config import read_toml

    raw = read_toml(SORT)
    raw["world"]["max_time"] = 60.0
    raw["bodies"]["green_bin"] = {**raw["bodies"]["red_bin"], "position": [green[0], green[1], 0.0]}
    raw["bodies"]["green"] = {**raw["bodies"]["red"], "rgba": [0.1, 0.8, 0.2, 1]}
    raw["regions"]["table"]["min_spacing"] = 0.09
    raw["sensors"]["truth"]["bodies"] += ["green_0", "green_1"]
    raw["behaviour"]["bins"]["green"] = {"body": "green_bin"}
    return raw


def reach_refusals(raw: dict[str, Any]) -> list[str]:
    with make_sim(raw, base_dir=SORT.parent) as sim:
        return [str(p) for p in sim.preflight() if "reach" in str(p)]


def test_a_green_bin_the_arm_can_drop_into_is_not_refused() -> None:
    """The arm cannot lower green_1 all the way into the bin's far slots, but it holds it over the bin and the
    sort's recovery opens the gripper there: the cube ends in the bin (the slow test below runs it), so validate
    does not refuse."""
    assert reach_refusals(three_colours((0.7, 0.42))) == []


def in_box(world: Any, body: str, box: str) -> bool:
    (x, y, z), _ = world.pose(body)
    (lx, ly, _), (hx, hy, hz) = world.body_aabb(box)
    return lx <= x <= hx and ly <= y <= hy and z <= hz


@pytest.mark.slow  # 17 runs of a six-cube sort
@pytest.mark.parametrize("green", GREEN)
def test_every_layout_validate_refuses_for_reach_fails_and_every_other_sorts(green: tuple[float, float]) -> None:
    raw = three_colours(green)
    refused = reach_refusals(raw)
    with make_sim(raw, base_dir=SORT.parent) as sim:
        result = sim.run()
        greens = [in_box(sim.world, n, "green_bin") for n in ("green_0", "green_1")]
    if refused:
        assert all("bins.green: bin 'green_bin' is out of the reach of arm 'arm'" in p for p in refused), refused
        assert result.outcome == "failed", (refused, result.reason)
        assert not all(greens)  # the world: a green cube is not in its bin
    else:
        assert result.outcome == "succeeded", result.reason
        assert all(greens)
