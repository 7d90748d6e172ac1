"""``robokit robot new`` and xacro robots in configs: every scaffold kind, on both engines, reaches its task's goal
as the world judges it (the go_to_goal robot's base within the tolerance of the goal; the cube resting on the pad),
unchanged; xacro arguments from the config reach the model; xacro mistakes are one line naming file and line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from robokit.cli import main
from robokit.core.simulation import build
from robokit.robot.check import check_robot, load
from robokit.robot.scaffold import KINDS, new_robot

GOALS = {"diffdrive": (5.0, 3.0), "arm": (0.45, -0.35), "gripper-arm": (0.45, -0.35)}


def _run_to_goal(tmp_path: Path, kind: str, engine: str) -> None:
    _, config = new_robot("bot", kind, tmp_path)
    sim = build(config, overrides={"world.engine": engine})
    with sim:
        sim.run()
        if kind == "diffdrive":
            x, y, _ = sim.world.pose("robot")[0]
            assert math.dist((x, y), GOALS[kind]) < 0.2 + 0.05
        else:
            x, y, z = sim.world.pose("cube")[0]
            assert math.dist((x, y), GOALS[kind]) < 0.02 and abs(z - 0.027) < 0.01
        assert sim.outcome is not None and sim.outcome.status == "succeeded"


def test_the_gripper_arm_scaffold_picks_the_cube_on_pybullet(tmp_path: Path) -> None:
    _run_to_goal(tmp_path, "gripper-arm", "pybullet")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
@pytest.mark.parametrize("kind", list(KINDS))
def test_every_scaffold_reaches_its_goal_on_both_engines(tmp_path: Path, kind: str, engine: str) -> None:
    _run_to_goal(tmp_path, kind, engine)


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_xacro_args_from_the_config_shape_the_robot(tmp_path: Path, engine: str) -> None:
    _, config = new_robot("bot", "diffdrive", tmp_path)
    wheel = 0.08
    sim = build(config, overrides={"world.engine": engine, "robots.robot.xacro_args.wheel_radius": wheel,
                                   "robots.robot.position": [0, 0, wheel]})
    with sim:
        w = sim.world
        left = w.link("robot", "left_wheel_link")
        for _ in range(240):
            sim.step()
        # the wheel's centre stands one (new) radius above the ground, the base level on it
        assert abs(w.pose("robot", left)[0][2] - wheel) < 0.005


def test_new_refuses_what_it_cannot_write(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robot", "new", "bot", "--kind", "arm", "-o", str(tmp_path)]) == 0
    assert (tmp_path / "bot.urdf.xacro").is_file() and (tmp_path / "bot.toml").is_file()
    assert main(["robot", "new", "bot", "--kind", "arm", "-o", str(tmp_path)]) == 2
    assert "bot.urdf.xacro already exists (--force writes over it)" in capsys.readouterr().err
    assert main(["robot", "new", "2bot", "--kind", "arm"]) == 2


def test_a_xacro_mistake_is_one_line_with_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    xacro, config = new_robot("bot", "diffdrive", tmp_path)
    text = xacro.read_text(encoding="utf-8").replace("${track / 2}", "${trak / 2}")
    xacro.write_text(text, encoding="utf-8")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "${trak / 2}" in s)
    assert main(["validate", str(config)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"{xacro}:{line}: xacro: name 'trak' is not defined" in err and "robots.robot" in err


LESSON = Path(__file__).resolve().parent.parent / "docs" / "lessons"


@pytest.mark.parametrize("page", ["09-design-your-robot.md", "09-design-your-robot.ko.md"])
def test_the_lesson_shows_what_the_checker_prints(tmp_path: Path, page: str, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """Lesson 09, step 2: the scaffold with the page's bigger wheels and chassis (and the old track)."""
    import re

    _, config = new_robot("mybot", "diffdrive", tmp_path)
    text = config.read_text(encoding="utf-8")
    for old, new in (("wheel_radius = 0.05, track", "wheel_radius = 0.07, track"),
                     ("chassis_length = 0.30, chassis_width = 0.20, chassis_mass = 2.0",
                      "chassis_length = 0.36, chassis_width = 0.34, chassis_mass = 3.0"),
                     ("position = [0, 0, 0.05]", "position = [0, 0, 0.07]")):
        assert old in text
        text = text.replace(old, new)
    config.write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["robot", "check", "mybot.toml"]) == 2
    shown = re.search(r"```text\n(.*?)```", (LESSON / page).read_text(encoding="utf-8"), re.S)
    assert shown is not None
    assert capsys.readouterr().err.strip().splitlines() == shown.group(1).strip().splitlines()


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
@pytest.mark.parametrize("robot", ["mybot", "myarm"])
def test_the_lesson_s_finished_robots_reach_their_goals(robot: str, engine: str, tmp_path: Path) -> None:
    config = LESSON / "09" / robot / f"{robot}.toml"
    with build(config, overrides={"world.engine": engine, "report.keep_local": False}) as sim:
        sim.run()
        assert sim.outcome is not None and sim.outcome.status == "succeeded"
        if robot == "myarm":
            x, y, _ = sim.world.pose("cube")[0]
            assert math.dist((x, y), GOALS["arm"]) < 0.02
        else:
            x, y, _ = sim.world.pose("robot")[0]
            assert math.dist((x, y), GOALS["diffdrive"]) < 0.25


MESH_ROBOT = """<?xml version="1.0"?>
<robot name="duckbot" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="scale" default="0.5"/>
  <link name="base_link">
    <inertial><mass value="1.0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <visual><geometry><mesh filename="meshes/duck.obj" scale="$(arg scale) $(arg scale) $(arg scale)"/></geometry>
    </visual>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
  </link>
</robot>
"""


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_xacro_robot_s_relative_meshes_load_from_the_cache(tmp_path: Path, engine: str) -> None:
    """The expanded URDF lives in the cache: a mesh named relative to the xacro file is found all the same."""
    import shutil

    import pybullet_data

    (tmp_path / "meshes").mkdir()
    shutil.copy(Path(pybullet_data.getDataPath()) / "duck.obj", tmp_path / "meshes" / "duck.obj")
    (tmp_path / "duckbot.urdf.xacro").write_text(MESH_ROBOT, encoding="utf-8")
    config = {"world": {"engine": engine}, "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
              "robots": {"duck": {"urdf": "duckbot.urdf.xacro", "position": [0, 0, 0.05], "fixed_base": True,
                                  "xacro_args": {"scale": 0.2}}}}
    with build(config, base_dir=tmp_path) as sim:
        assert sim.world.has_body("duck")
        assert check_robot(load(tmp_path / "duckbot.urdf.xacro")) == []
