"""``robokit robot show`` (three views, joint frames projected where the joints are), ``robokit inspect``'s masses
and inertias (against the file, read independently), and ``robokit validate`` refusing a config whose robot the
checker refuses."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest

from robokit.cli import main
from robokit.robot.scaffold import new_robot

ROOT = Path(__file__).resolve().parent.parent


def test_show_draws_three_views_with_the_joint_axes(tmp_path: Path) -> None:
    xacro, _ = new_robot("arm1", "gripper-arm", tmp_path)
    out = tmp_path / "arm.png"
    assert main(["robot", "show", str(xacro), "-o", str(out), "--size", "240"]) == 0
    img = cv2.imread(str(out))
    assert img.shape[:2] == (240, 3 * 320)
    # the joint axes are drawn in yellow (BGR 0, 200, 255) in each of the three views
    yellow = np.all(np.abs(img.astype(int) - (0, 200, 255)) < 40, axis=2)
    for view in range(3):
        assert yellow[:, view * 320:(view + 1) * 320].sum() > 30
    assert not list(tmp_path.glob(".*tmp*"))


def test_inspect_lists_masses_and_inertias_as_the_file_has_them(capsys: pytest.CaptureFixture[str]) -> None:
    path = ROOT / "robokit" / "data" / "robots" / "diffbot.urdf"
    assert main(["inspect", str(path), "--json"]) == 0
    links = {r["link"]: r for r in json.loads(capsys.readouterr().out)["links"]}
    root = ET.parse(path).getroot()
    for link in root.findall("link"):
        mass = float(link.find("inertial/mass").get("value"))  # type: ignore[union-attr]
        inertia = link.find("inertial/inertia")
        assert links[link.get("name")]["mass"] == pytest.approx(mass)
        for key in ("ixx", "iyy", "izz"):
            assert links[link.get("name")]["inertia"][key] == pytest.approx(float(inertia.get(key)))  # type: ignore[union-attr, arg-type]
    assert main(["inspect", str(path)]) == 0
    assert "links: total mass 2.480 kg" in capsys.readouterr().out


def test_inspect_reads_a_xacro_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    xacro, _ = new_robot("bot", "diffdrive", tmp_path)
    assert main(["inspect", str(xacro)]) == 0
    out = capsys.readouterr().out
    assert "left_wheel" in out and "base_link" in out and "2.000" in out


def test_validate_refuses_a_robot_the_checker_refuses(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, config = new_robot("bot", "diffdrive", tmp_path)
    text = config.read_text(encoding="utf-8").replace("chassis_width = 0.20", "chassis_width = 0.34")
    config.write_text(text, encoding="utf-8")
    assert main(["validate", str(config)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all("robots.robot: bot.urdf.xacro: joint '" in e and "[wheels]" in e for e in err)
    config.write_text(text.replace("track = 0.28", "track = 0.42"), encoding="utf-8")
    assert main(["validate", str(config)]) == 0


def test_the_replay_draws_the_xacro_robot_with_the_config_s_arguments(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.record.format import find_run
    from robokit.record.replay import replay_of

    _, config = new_robot("arm1", "gripper-arm", tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["run", config.name, "--quiet", "--set", "robots.robot.xacro_args.upper_arm=0.45",
                 "--set", "world.max_time=0.2"]) in (0, 1)
    replay = replay_of(find_run("last", tmp_path / "results"))
    frames = {link.path: k for k, link in enumerate(replay.links)}
    assert {"robot/upper_arm", "robot/finger_left_link", "robot/finger_right_link"} <= set(frames)
    upper = [s for s in replay.shapes if s.frame == frames["robot/upper_arm"]]
    assert [s.kind for s in upper] == ["box"] and np.allclose(upper[0].size, (0.05, 0.05, 0.45))
