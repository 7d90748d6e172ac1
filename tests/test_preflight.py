"""``robokit validate`` knows the task: what can be checked without running is checked, one line per problem
naming the key, exit 2 — and everything ``run`` refuses, ``validate`` refuses first."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from robokit import hookimpl
from robokit.components import Sensor
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


def robokit(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def edited(folder: Path, config: str, edits: list[tuple[str, str]], extra: str = "") -> Path:
    text = (CONFIGS / config).read_text(encoding="utf-8")
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    path = folder / config
    path.write_text(text + extra, encoding="utf-8")
    return path


def refused(path: Path, cwd: Path) -> list[str]:
    """Run ``robokit validate``; assert exit 2 and no traceback; return the error lines."""
    proc = robokit("validate", str(path), cwd=cwd)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines and all(line.startswith(f"robokit: error: {path}: ") for line in lines), lines
    return lines


@pytest.mark.parametrize("config", sorted(p.name for p in CONFIGS.glob("*.toml")))
def test_shipped_configs_pass_every_preflight_check(config: str) -> None:
    with make_sim(CONFIGS / config) as sim:
        assert sim.preflight() == []


def test_a_one_ray_lidar_is_refused_by_the_avoider(tmp_path: Path) -> None:
    path = edited(tmp_path, "patrol.toml", [("rays = 360", "rays = 1")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.scan: lidar 'scan' has 1 ray(s)" in line and "rays = " in line, line
    assert robokit("run", str(path), cwd=tmp_path).returncode == 2  # run refuses it too


def test_a_coarse_but_sufficient_lidar_passes(tmp_path: Path) -> None:
    path = edited(tmp_path, "patrol.toml", [("rays = 360", "rays = 36")])  # one ray every 10 degrees
    assert robokit("validate", str(path), cwd=tmp_path).returncode == 0


def test_a_waypoint_outside_the_walled_arena_is_refused(tmp_path: Path) -> None:
    path = edited(tmp_path, "patrol_robot.toml", [("waypoints = [[5.0, 3.0]", "waypoints = [[8.0, 3.0]")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.waypoints[0]: (8, 3) is outside the map's extent" in line, line


def test_a_goal_off_the_floor_is_refused(tmp_path: Path) -> None:
    text = (CONFIGS / "go_to_goal.toml").read_text(encoding="utf-8")
    assert "goal = " in text
    path = edited(tmp_path, "go_to_goal.toml", [(text[text.index("goal = "):].splitlines()[0], "goal = [150.0, 0.0]")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.goal: (150, 0) is outside the floor" in line, line


OVERLAP = """
[bodies.sunk]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.1
position = [0.7, 0.3, 0.0]
"""


def test_two_bodies_spawned_overlapping_are_refused(tmp_path: Path) -> None:
    path = edited(tmp_path, "pick_place.toml", [], OVERLAP)  # half sunk into the table top
    (line,) = refused(path, tmp_path)
    assert "bodies.sunk: 'sunk' is spawned overlapping 'table' (bodies.table) by 24 mm" in line, line


@pytest.mark.slow
def test_pick_place_without_place_position_is_refused_by_validate_and_run(tmp_path: Path) -> None:
    path = edited(tmp_path, "pick_place.toml", [("place_position = [0.45, -0.35, 0.027]\n", "")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.place_position: missing: pick_place needs the object centre at the place spot" in line, line
    assert robokit("run", str(path), cwd=tmp_path).returncode == 2


@pytest.mark.slow
def test_pick_place_place_out_of_reach_is_refused(tmp_path: Path) -> None:
    path = edited(tmp_path, "pick_place.toml", [("place_position = [0.45, -0.35, 0.027]",
                                                 "place_position = [0.45, -0.95, 0.027]")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.place_position: out of the reach of arm 'arm': unreachable: " in line, line


def test_a_nan_goal_is_refused_by_validate(tmp_path: Path) -> None:
    text = (CONFIGS / "go_to_goal.toml").read_text(encoding="utf-8")
    path = edited(tmp_path, "go_to_goal.toml", [(text[text.index("goal = "):].splitlines()[0], "goal = [nan, 1.0]")])
    (line,) = refused(path, tmp_path)
    assert "behaviour.goal" in line, line


# --------------------------------------------------------------------- a third-party type adds its own check
class Thermometer(Sensor):
    """Complains before the run when a body it should watch is missing; reads nothing."""

    def preflight(self, ctx):  # type: ignore[no-untyped-def]
        return [] if ctx.world.has_body("oven") else [ctx.problem("no body 'oven' to watch", "body")]

    def read(self) -> float:
        return 20.0


class ThermoPlugin:
    @hookimpl
    def robokit_register_sensors(self, register):  # type: ignore[no-untyped-def]
        register("thermometer", Thermometer, None)


def test_third_party_preflight_problems_are_gathered_with_file_and_key() -> None:
    with make_sim({"sensors": {"t": {"type": "thermometer"}}}, extra_plugins=(ThermoPlugin(),)) as sim:
        (problem,) = sim.preflight()
    assert str(problem) == "<dict>: sensors.t.body: no body 'oven' to watch"
