"""Every shipped config validates: its URDFs exist and every named body, joint and link resolves."""

from __future__ import annotations

from pathlib import Path

import pytest

from robokit.cli import main

CONFIGS = sorted((Path(__file__).resolve().parent.parent / "configs").glob("*.toml"))


def test_there_is_a_config_per_lesson_and_the_main_jobs() -> None:
    names = {p.stem for p in CONFIGS}
    assert {"sort_robot", "pick_place", "patrol_robot", "drop_test", "urdf_gallery", "kuka_dance", "contact_stop",
            "camera_demo", "go_to_goal", "patrol", "drive_teleop", "kuka_teleop"} <= names


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_config_validates(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err
    assert capsys.readouterr().out.startswith(f"{path}: ok (")
