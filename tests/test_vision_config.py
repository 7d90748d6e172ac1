"""Vision config errors: one clear line at ``robokit validate``, exit code 2, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from robokit.testing import validate_error

HEAD = """
[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[robots.panda]
urdf = "franka_panda/panda.urdf"
position = [0, 0, 0]
fixed_base = true
"""


def validate(tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    path = tmp_path / "scene.toml"
    path.write_text(HEAD + text, encoding="utf-8")
    return 2, validate_error(path)


def test_camera_on_unknown_link(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, """
[sensors.wrist_cam]
type = "camera"
mount_body = "panda"
mount_link = "panda_hnad"
""", capsys)
    assert code == 2
    assert "sensors.wrist_cam.mount_link: unknown link 'panda_hnad'" in line
    assert "did you mean 'panda_hand'" in line and "panda_grasptarget" in line


def test_camera_on_unknown_body(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, """
[sensors.wrist_cam]
type = "camera"
mount_body = "pnada"
mount_link = "panda_hand"
""", capsys)
    assert code == 2 and "sensors.wrist_cam.mount_body: unknown body 'pnada'" in line


def test_detector_pointing_at_unknown_camera(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, """
[sensors.cam]
type = "camera"

[sensors.det]
type = "colour_detector"
camera = "kam"
""", capsys)
    assert code == 2
    assert "sensors.det.camera: unknown camera sensor 'kam' (did you mean 'cam'?); valid: cam" in line


def test_bad_hue_range(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, """
[sensors.cam]
type = "camera"

[sensors.det]
type = "colour_detector"
colours.red = { hue_deg = [350, 400] }
""", capsys)
    assert code == 2 and "sensors.det.colours.red" in line and "hue_deg must lie in 0..360" in line


def test_camera_far_before_near(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, """
[sensors.cam]
type = "camera"
near = 2.0
far = 1.0
""", capsys)
    assert code == 2 and "sensors.cam" in line and "far (1.0) must be greater than near (2.0)" in line
