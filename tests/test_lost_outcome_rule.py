"""The outcome rule (README, "How a run ends"): once the behaviour ends the run, the world's goal is the verdict,
both ways, and the reason says why. Behaviours that over-claim (say succeeded, the world disagrees) and under-claim
(say failed, the world shows the task done), and the main job's sort with a retried pick."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from robokit import hookimpl
from robokit.components import Behaviour, GoalCheck
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]


class Drops(Behaviour):
    """Says what it is told; its goal is a world fact it does not control: the ball (dropped from 0.5 m) is below
    ``below`` metres at the end."""

    def step(self, readings: Mapping[str, Any], t: float) -> Any:
        if t >= 1.0:
            self.finish(self.config["claim"], self.config.get("why", "it says so"))
        return None

    def check_goal(self, world: Any) -> GoalCheck:
        z = world.pose("ball")[0][2]
        return GoalCheck(z < self.config["below"], f"ball at z = {z:.3f} m", {"z": round(z, 3)})

    def result(self) -> dict[str, Any]:
        return {"misses": {"count": 1, "reasons": ["first grab slipped"]}}


class DropsPlugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("drops", Drops, None)


def run(**params: Any) -> Any:
    config = {"bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                         "ball": {"shape": "sphere", "radius": 0.05, "position": [0, 0, 0.5]}},
              "behaviour": {"type": "drops"}}
    with make_sim(config, extra_plugins=(DropsPlugin(),)) as sim:
        sim.behaviour.config = params
        result = sim.run(max_time=3.0)
        ball_z = sim.world.pose("ball")[0][2]
    return result, ball_z


def test_under_claim_a_failure_the_world_shows_done_is_succeeded_and_the_claim_is_kept() -> None:
    result, z = run(claim="failed", why="IK residual 1.2 mm > 0.5 mm on the way down", below=0.1)
    assert z == pytest.approx(0.05, abs=0.005)  # the ball rests on the plane: the goal holds, by geometry
    assert (result.outcome, result.exit_code) == ("succeeded", 0)
    assert result.reason == (f"goal met: ball at z = {z:.3f} m (the behaviour reported failed: IK residual 1.2 mm "
                             "> 0.5 mm on the way down)")
    assert result.result["goal"]["claimed"] == {"outcome": "failed",
                                                "reason": "IK residual 1.2 mm > 0.5 mm on the way down"}
    assert result.result["misses"] == {"count": 1, "reasons": ["first grab slipped"]}  # reported, not a failure


def test_over_claim_a_success_the_world_denies_is_failed_naming_why_first() -> None:
    result, z = run(claim="succeeded", below=0.01)
    assert z > 0.01
    assert (result.outcome, result.exit_code) == ("failed", 1)
    assert result.reason == f"goal not met: ball at z = {z:.3f} m (the behaviour reported succeeded: it says so)"
    assert result.result["goal"]["met"] is False


def test_honest_claims_are_kept_as_they_are() -> None:
    ok, _ = run(claim="succeeded", below=0.1)
    assert (ok.outcome, ok.reason) == ("succeeded", "it says so") and "claimed" not in ok.result["goal"]
    bad, z = run(claim="failed", below=0.01)
    assert (bad.outcome, bad.reason) == ("failed", f"goal not met: ball at z = {z:.3f} m (the behaviour reported "
                                                   "failed: it says so)")


def test_a_run_stopped_by_its_time_limit_is_not_judged() -> None:
    config = {"bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                         "ball": {"shape": "sphere", "radius": 0.05, "position": [0, 0, 0.5]}},
              "behaviour": {"type": "drops"}}
    with make_sim(config, extra_plugins=(DropsPlugin(),)) as sim:
        sim.behaviour.config = {"claim": "succeeded", "below": 0.1}
        result = sim.run(max_time=0.5)  # ends before the behaviour's 1 s: the ball has landed, goal met
    assert result.outcome == "aborted" and result.reason.startswith("max_time 0.5 s reached")


GREEN = """
[bodies.green_bin]
urdf = "tray/traybox.urdf"
position = [0.8, 0.0, 0]
scale = 0.5
fixed_base = true

[bodies.green]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.1
region = "table"
count = 2
yaw_deg_range = [-45, 45]
rgba = [0.1, 0.8, 0.2, 1]
lateral_friction = 1.0

"""


def three_colour_sort(folder: Path) -> Path:
    """The main job plus two green cubes and a green bin far out at x = 0.8 m (0.3 m square tray at scale 0.5)."""
    text = (ROOT / "configs" / "sort_robot.toml").read_text(encoding="utf-8")
    for old, new in [('bodies = ["red_0", "red_1", "blue_0", "blue_1"]',
                      'bodies = ["red_0", "red_1", "blue_0", "blue_1", "green_0", "green_1"]'),
                     ('bins.blue = { body = "blue_bin" }',
                      'bins.blue = { body = "blue_bin" }\nbins.green = { body = "green_bin" }'),
                     ("[sensors.camera]", GREEN + "[sensors.camera]")]:
        assert old in text
        text = text.replace(old, new, 1)
    path = folder / "three.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.slow  # the whole three-colour job: ~8 s on a loaded machine
def test_a_sort_whose_cube_lands_after_a_retried_pick_succeeds_with_the_retry_in_the_result(tmp_path: Path) -> None:
    with make_sim(three_colour_sort(tmp_path), seed=0) as sim:
        result = sim.run()
        cubes = {name: sim.world.pose(name)[0] for name in ("green_0", "green_1")}
    for name, (x, y, z) in cubes.items():  # each green cube inside the green tray's 0.3 m square, resting low
        assert abs(x - 0.8) < 0.15 and abs(y) < 0.15 and z < 0.1, (name, x, y, z)
    assert result.outcome == "succeeded", result.reason
    misses = result.result["misses"]
    assert misses["count"] >= 1 and len(misses["reasons"]) == misses["count"]
    retried = [o for o in result.result["objects"] if o["attempts"] > 1]
    assert retried and all(o["outcome"] == "sorted" for o in retried)
    assert result.result["picks"] == 6 + misses["count"]
    assert math.isclose(result.result["failures"], misses["count"])
