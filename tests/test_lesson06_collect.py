"""Lesson 06 as taught: pick_place over several objects (known positions or names) onto one spot, stacking."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from robokit_behaviours.pick_place_jobs import stacked_place

from robokit.cli import main
from robokit.config import read_toml
from robokit.msgs import BodyState
from robokit.testing import edited_config, make_sim, validate_error

ROOT = Path(__file__).resolve().parents[1]
COLLECT = ROOT / "configs" / "lesson06_collect.toml"


def body(x: float, y: float, z: float) -> BodyState:
    return BodyState((x, y, z), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def test_the_place_height_is_measured_from_what_is_on_the_spot() -> None:
    spot = (0.45, -0.3, 0.027)
    assert stacked_place(spot, {}, 0.05, None) == spot
    one = {"a": body(0.452, -0.301, 0.027), "far": body(0.6, 0.2, 0.025)}
    assert stacked_place(spot, one, 0.05, None) == pytest.approx((0.45, -0.3, 0.077))
    two = {**one, "b": body(0.449, -0.299, 0.0772)}
    assert stacked_place(spot, two, 0.05, None) == pytest.approx((0.45, -0.3, 0.1272))
    assert stacked_place(spot, two, 0.05, "b") == pytest.approx((0.45, -0.3, 0.077))  # not onto itself


def test_lesson06_collect_runs_from_the_cli_and_stacks_three_cubes(tmp_path: Path, monkeypatch: Any,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(COLLECT), "--json"]) == 0
    run = json.loads(capsys.readouterr().out)
    assert run["outcome"] == "succeeded" and run["reason"] == "placed 3 objects in 3 attempt(s)"
    result = run["result"]
    assert result["placed"] == 3 and [job["object"] for job in result["jobs"]] == ["cube_a", "cube_b", "cube_c"]
    assert [job["place_position"][2] for job in result["jobs"]] == pytest.approx([0.027, 0.077, 0.127], abs=0.003)
    goal = result["goal"]
    assert goal["met"] and goal["reason"] == "all 3 objects rest on the place spot"
    finals = sorted(obj["final_position"] for obj in goal["objects"])
    assert [f[2] for f in sorted(finals, key=lambda f: f[2])] == pytest.approx([0.027, 0.077, 0.127], abs=0.004)
    assert all(abs(f[0] - 0.45) < 0.01 and abs(f[1] + 0.3) < 0.01 for f in finals)  # one tidy stack


def test_objects_by_name_onto_an_occupied_spot(tmp_path: Path) -> None:
    raw = read_toml(COLLECT)
    raw["bodies"]["cube_a"]["position"] = [0.45, -0.3, 0.027]  # already on the spot
    behaviour = raw["behaviour"]
    del behaviour["pick_positions"]
    behaviour["objects"] = ["cube_c", "cube_b"]
    with make_sim(raw, base_dir=ROOT / "configs") as sim:
        result = sim.run()
    assert result.outcome == "succeeded", result.reason
    tops = {j["object"]: j["final_position"][2] for j in result.result["jobs"]}
    assert tops == pytest.approx({"cube_c": 0.077, "cube_b": 0.127}, abs=0.004)
    assert result.result["goal"]["met"]


def test_a_single_object_is_placed_on_top_of_what_is_there() -> None:
    raw = read_toml(COLLECT)
    raw["bodies"]["cube_a"]["position"] = [0.45, -0.3, 0.027]
    behaviour = raw["behaviour"]
    del behaviour["pick_positions"]
    behaviour["object"] = "cube_b"
    with make_sim(raw, base_dir=ROOT / "configs") as sim:
        result = sim.run()
        cube_b = sim.world.pose("cube_b")[0]
    assert result.outcome == "succeeded", result.reason
    assert result.result["place_position"][2] == pytest.approx(0.077, abs=0.003)
    assert cube_b[2] == pytest.approx(0.077, abs=0.004) and result.result["goal"]["met"]


def test_pick_place_needs_something_to_pick(tmp_path: Path) -> None:
    none = edited_config(COLLECT, tmp_path, "pick_positions = [[0.45, 0.15, 0.025], [0.55, 0.0, 0.025], "
                         "[0.6, 0.2, 0.025]]", "", name="none.toml")
    assert "behaviour.object: missing: pick_place needs the body to pick" in validate_error(none)
    ghost = edited_config(COLLECT, tmp_path, "pick_positions = [[0.45, 0.15, 0.025], [0.55, 0.0, 0.025], "
                          "[0.6, 0.2, 0.025]]", 'objects = ["cube_a", "cube_x"]', name="ghost.toml")
    assert "behaviour.objects[1]: unknown body 'cube_x'" in validate_error(ghost)
