"""``robokit robot check``: every broken robot of tests/broken_robots/ is refused with the line its header names;
every bundled robot and every pybullet_data robot the configs load passes (warnings allowed, no errors)."""

from __future__ import annotations

import re
from pathlib import Path

import pybullet_data
import pytest

from robokit.cli import main
from robokit.robot.check import CHECKS, check_robot, load

ROOT = Path(__file__).resolve().parent.parent
CORPUS = sorted((ROOT / "tests" / "broken_robots").glob("*.urdf"))
EXPECT = re.compile(r"expect: (\S+) \| (.+?) -->")


def _expected(path: Path) -> tuple[str, str]:
    check, where = EXPECT.search(path.read_text(encoding="utf-8")).groups()  # type: ignore[union-attr]
    return check, where


def _config_robots() -> list[Path]:
    """Every URDF a config under configs/ loads (bundled, pybullet_data or beside the config)."""
    out = set()
    for config in (ROOT / "configs").rglob("*.toml"):
        for name in re.findall(r'^urdf = "([^"]+)"', config.read_text(encoding="utf-8"), re.M):
            for cand in (config.parent / name, ROOT / "robokit" / "data" / name,
                         Path(pybullet_data.getDataPath()) / name):
                if cand.is_file():
                    out.add(cand.resolve())
                    break
    return sorted(out)


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.stem)
def test_each_broken_robot_is_refused_with_its_line(path: Path) -> None:
    check, where = _expected(path)
    problems = [p for p in check_robot(load(path)) if not p.warning or p.check == check]
    assert any(p.check == check and p.where == where for p in problems), [p.text(path.name) for p in problems]
    for p in problems:  # one line each, naming the element and the fix
        assert "\n" not in p.text(path) and "; fix: " in p.text(path) and p.where


def test_the_corpus_covers_every_check() -> None:
    assert {_expected(p)[0] for p in CORPUS} == set(CHECKS)


@pytest.mark.parametrize("path", [*_config_robots(), *sorted((ROOT / "robokit" / "data" / "robots").glob("*.urdf"))],
                         ids=lambda p: p.name)
def test_valid_robots_are_never_refused(path: Path) -> None:
    assert [p.text(path.name) for p in check_robot(load(path)) if not p.warning] == []


@pytest.mark.parametrize("tool", ["suction", "gripper"])
def test_the_scaffolds_pass(tool: str) -> None:
    scaffold = ROOT / "robokit" / "data" / "robots" / "scaffold"
    assert check_robot(load(scaffold / "arm.urdf.xacro", {"tool": tool})) == []
    assert check_robot(load(scaffold / "diffdrive.urdf.xacro")) == []


def test_the_command_exits_2_with_one_line_per_problem(capsys: pytest.CaptureFixture[str]) -> None:
    path = ROOT / "tests" / "broken_robots" / "duplicate_link.urdf"
    assert main(["robot", "check", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].endswith("2 problems")
    assert err[0].startswith(f"{path}:43: link 'left_wheel_link': the name is used twice (first at line 25)")
    assert main(["robot", "check", "robots/diffbot.urdf"]) == 0
    assert capsys.readouterr().out.strip() == "robots/diffbot.urdf: ok (7 links, 6 joints)"


def test_a_xacro_robot_is_checked_with_its_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The lesson's mistake: a chassis wider than the track buries the wheels; the fix is a wider track."""
    xacro = ROOT / "robokit" / "data" / "robots" / "scaffold" / "diffdrive.urdf.xacro"
    assert main(["robot", "check", str(xacro), "--arg", "chassis_width=0.34"]) == 2
    err = capsys.readouterr().err
    assert f"{xacro}: joint 'left_wheel': wheel 'left_wheel_link' is sunk" in err and "[wheels]" in err
    assert main(["robot", "check", str(xacro), "--arg", "chassis_width=0.34", "--arg", "track=0.42"]) == 0


def test_check_reads_a_config_s_robots_with_their_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from robokit.robot.scaffold import new_robot

    _, config = new_robot("bot", "diffdrive", tmp_path)
    assert main(["robot", "check", str(config)]) == 0
    assert capsys.readouterr().out.strip() == f"{config} [robots.robot] bot.urdf.xacro: ok (5 links, 4 joints)"
    config.write_text(config.read_text(encoding="utf-8").replace("chassis_width = 0.20", "chassis_width = 0.34"),
                      encoding="utf-8")
    assert main(["robot", "check", str(config)]) == 2
    assert "[robots.robot] bot.urdf.xacro: 2 problems" in capsys.readouterr().err
