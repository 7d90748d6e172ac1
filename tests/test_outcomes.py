"""Outcomes tell the truth: every task's goal is checked on the world at the end, and the summary says why not.

The sort scenes are the main job's scene cut to one red and one blue cube (fast), with one thing changed each:
a colour written 0-255, a cube of a colour no detector class knows, a cube outside the camera's view, a bin out
of the arm's reach. ``robokit validate`` refuses each, naming the key; ``robokit run`` runs it anyway and ends
``failed`` with a reason naming the object and why.
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from robokit import hookimpl
from robokit.components import Behaviour, GoalCheck
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
SORT = ROOT / "configs" / "sort_robot.toml"
TWO_CUBES = [("count = 2", "count = 1"),
             ('bodies = ["red_0", "red_1", "blue_0", "blue_1"]', 'bodies = ["red", "blue"]')]


def robokit(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def sort_scene(folder: Path, edits: list[tuple[str, str]] = (), extra: str = "") -> Path:  # type: ignore[assignment]
    """sort_robot.toml with one red and one blue cube, ``edits`` applied (each must match) and ``extra`` added."""
    text = SORT.read_text(encoding="utf-8")
    for old, new in [*TWO_CUBES, *edits]:
        assert old in text, old
        text = text.replace(old, new)
    path = folder / "scene.toml"
    path.write_text(text + extra, encoding="utf-8")
    return path


def outcome_line(stdout: str) -> str:
    return next(line for line in stdout.splitlines() if line.startswith("outcome:"))


def error_lines(stderr: str) -> list[str]:
    assert "Traceback" not in stderr, stderr
    return [line for line in stderr.splitlines() if line.startswith("robokit: error:")]


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_the_trimmed_scene_itself_validates_and_sorts(tmp_path: Path) -> None:
    scene = sort_scene(tmp_path)
    assert robokit("validate", str(scene), cwd=tmp_path).returncode == 0
    proc = robokit("run", str(scene), "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["outcome"] == "succeeded"
    assert (out["result"]["red_sorted"], out["result"]["blue_sorted"]) == (1, 1)
    assert out["result"]["goal"] == {"met": True, "reason": "all 2 sortable object(s) in their bins",
                                     "in_bin": ["blue", "red"], "missed": {}}


def test_colours_written_0_255_are_refused_naming_the_key(tmp_path: Path) -> None:
    scene = sort_scene(tmp_path, [("rgba = [0.9, 0.1, 0.1, 1]", "rgba = [230, 25, 25, 255]")])
    for command in ("validate", "run"):
        proc = robokit(command, str(scene), cwd=tmp_path)
        assert proc.returncode == 2, (command, proc.stdout, proc.stderr)
        (line,) = error_lines(proc.stderr)
        assert "bodies.red.rgba" in line and "0-1" in line, line
    assert not list(tmp_path.glob("results/*")), "a refused config runs nothing"


PURPLE = """
[bodies.purple]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.1
position = [0.62, 0.12, 0.025]
rgba = [0.55, 0.1, 0.9, 1]
"""
AVOID_PURPLE = ("min_spacing = 0.1", 'min_spacing = 0.1\navoid = ["purple"]\nclearance = 0.06')


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_a_colour_no_detector_class_knows_fails_validate_and_the_run_names_it(tmp_path: Path) -> None:
    scene = sort_scene(tmp_path, [AVOID_PURPLE], PURPLE)
    proc = robokit("validate", str(scene), cwd=tmp_path)
    assert proc.returncode == 2
    (line,) = error_lines(proc.stderr)
    assert "bodies.purple.rgba" in line and "matches no colour class" in line, line
    run = robokit("run", str(scene), cwd=tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "bodies.purple.rgba" in run.stderr  # the same problem, printed as a warning before the run
    line = outcome_line(run.stdout)
    assert line.startswith("outcome: failed (goal not met: 1 of 3 object(s) not in their bin: purple (its colour"), line
    assert "red_sorted: 1" in run.stdout and "blue_sorted: 1" in run.stdout  # the others were sorted


STRAY = """
[bodies.stray]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.1
position = [0.08, 0.6, 0.025]
rgba = [0.9, 0.1, 0.1, 1]
lateral_friction = 1.0
"""


@pytest.mark.slow
def test_an_object_outside_the_camera_view_fails_validate_and_the_run_names_it(tmp_path: Path) -> None:
    scene = sort_scene(tmp_path, [], STRAY)
    proc = robokit("validate", str(scene), cwd=tmp_path)
    assert proc.returncode == 2
    (line,) = error_lines(proc.stderr)
    assert "bodies.stray:" in line and "outside the view of camera 'camera'" in line, line
    run = robokit("run", str(scene), "--json", cwd=tmp_path)
    assert run.returncode == 1
    out = json.loads(run.stdout)
    assert out["outcome"] == "failed"
    assert "stray (never seen by detector 'detector')" in out["reason"], out["reason"]
    assert out["result"]["goal"]["missed"] == {"stray": "never seen by detector 'detector'"}
    assert out["result"]["red_sorted"] == 1  # counted in the world: the stray red cube is not in the bin


@pytest.mark.slow
def test_a_bin_out_of_reach_fails_validate_naming_the_bin_and_the_run_says_unreachable(tmp_path: Path) -> None:
    scene = sort_scene(tmp_path, [("position = [0.35, 0.42, 0]", "position = [0.35, 0.95, 0]"),
                                  ("object_size = 0.05\n", "object_size = 0.05\nmax_attempts = 1\n")])
    proc = robokit("validate", str(scene), cwd=tmp_path)
    assert proc.returncode == 2
    (line,) = error_lines(proc.stderr)
    assert "behaviour.bins.red:" in line and "'red_bin'" in line and "reach" in line, line
    run = robokit("run", str(scene), cwd=tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    line = outcome_line(run.stdout)
    assert line.startswith("outcome: failed (") and "red (arm failed in TRANSPORT: unreachable" in line, line
    assert "red_sorted: 0" in run.stdout and "blue_sorted: 1" in run.stdout


# --------------------------------------------------------------------- the mechanism, for any behaviour
class Claims(Behaviour):
    """Finishes at once with whatever outcome it is told, and states a goal the world decides: ``box`` below z."""

    def step(self, readings: Mapping[str, Any], t: float) -> Any:
        if self.config.get("step_raises"):
            raise RuntimeError("the step broke")
        if self.config.get("command"):
            return {"arm": 1}
        self.finish(self.config["claim"], "done, it says")
        return None

    def check_goal(self, world: Any) -> GoalCheck:
        z = world.pose("box")[0][2]
        if self.config.get("raise"):
            raise RuntimeError("goal check broke")
        return GoalCheck(z < self.config["below"], f"box at z = {z:.2f} m", {"z": round(z, 3)})


class ClaimsPlugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("claims", Claims, None)


def claims_run(**params: Any) -> Any:
    config = {"bodies": {"box": {"shape": "box", "mass": 0, "position": [0, 0, 1.0]}}, "behaviour": {"type": "claims"}}
    with make_sim(config, extra_plugins=(ClaimsPlugin(),)) as sim:
        sim.behaviour.config = params
        return sim.run(max_time=1.0)


def test_a_claimed_success_whose_goal_does_not_hold_ends_failed_with_the_goal_reason() -> None:
    result = claims_run(claim="succeeded", below=0.5)
    assert result.outcome == "failed" and result.exit_code == 1
    assert result.reason == "goal not met: box at z = 1.00 m (the behaviour reported succeeded: done, it says)"
    assert result.result["goal"] == {"met": False, "reason": "box at z = 1.00 m", "z": 1.0,
                                     "claimed": {"outcome": "succeeded", "reason": "done, it says"}}


def test_a_goal_that_holds_keeps_the_outcome_and_is_recorded() -> None:
    result = claims_run(claim="succeeded", below=2.0)
    assert (result.outcome, result.reason) == ("succeeded", "done, it says")
    assert result.result["goal"]["met"] is True


def test_a_failure_keeps_failing_and_the_goal_reason_comes_first() -> None:
    result = claims_run(claim="failed", below=0.5)
    assert (result.outcome, result.reason) == ("failed", "goal not met: box at z = 1.00 m (the behaviour reported "
                                                         "failed: done, it says)")


def test_a_goal_check_that_raises_is_a_plugin_error_naming_the_type() -> None:
    result = claims_run(claim="succeeded", below=2.0, **{"raise": True})
    assert result.outcome == "error" and result.exit_code == 3
    assert "behaviour type 'claims'" in result.reason and "check_goal" in result.reason


def test_a_run_ended_by_a_plugin_error_is_not_goal_checked() -> None:
    result = claims_run(claim="succeeded", below=0.5, step_raises=True)
    assert result.outcome == "error" and "RuntimeError: the step broke" in result.reason
    assert "goal" not in result.result and "goal not met" not in result.reason


def test_a_command_to_an_actuator_that_does_not_exist_names_the_actuators() -> None:
    result = claims_run(claim="succeeded", below=2.0, command=True)
    assert result.outcome == "error"
    assert result.reason.endswith("sent a command to unknown actuator 'arm'; actuators: (none)"), result.reason


@pytest.mark.parametrize("offset, met", [((0.0, 0.0, 0.0), True), ((0.03, 0.0, 0.0), False)])
def test_pick_place_goal_is_the_object_resting_at_the_place_pose(offset: tuple[float, ...], met: bool) -> None:
    with make_sim(ROOT / "configs" / "pick_place.toml", seed=3) as sim:
        assert sim.run_until(lambda s: s.outcome is not None, 240 * 8)
        place = sim.config.behaviour.params.place_position  # type: ignore[union-attr]
        sim.world.set_pose("cube", [p + o for p, o in zip(place, offset, strict=True)])
        sim.step(60)  # settles where it was put
        check = sim.behaviour.check_goal(sim.world)
    assert check.met is met, check.reason
    assert check.details["placement_error"] == pytest.approx(offset[0], abs=0.004)
