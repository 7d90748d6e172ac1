"""Sort config errors (one line at ``robokit validate``, exit 2) and its Mermaid diagram (``robokit graph sort``)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main
from robokit.testing import edited_config, validate_error

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "sort_robot.toml"


def validate(tmp_path: Path, old: str, new: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    return 2, validate_error(edited_config(CONFIG, tmp_path, old, new, name="sort.toml"))


def test_sort_robot_validates(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(CONFIG)]) == 0
    assert "ok" in capsys.readouterr().out


def test_bin_for_an_undefined_colour(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, 'bins.blue = { body = "blue_bin" }', 'bins.bleu = { body = "blue_bin" }', capsys)
    assert code == 2
    assert "behaviour.bins.bleu: bin for undefined colour 'bleu' (did you mean 'blue'?)" in line
    assert "red, green, blue, yellow" in line


def test_bin_on_an_unknown_body(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, 'bins.red = { body = "red_bin" }', 'bins.red = { body = "red_box" }', capsys)
    assert code == 2 and "behaviour.bins.red.body: unknown body 'red_box' (did you mean 'red_bin'?)" in line


def test_sort_without_a_detector(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, 'detector = "detector"\narm', 'detector = "detektor"\narm', capsys)
    assert code == 2
    assert "behaviour.detector: unknown colour_detector sensor 'detektor' (did you mean 'detector'?)" in line


def test_sort_with_an_unknown_arm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, line = validate(tmp_path, 'arm = "arm"\ngripper', 'arm = "hand"\ngripper', capsys)
    assert code == 2 and "behaviour.arm" in line and "ik_arm" in line


def test_graph_sort_prints_mermaid(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["graph", "sort"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("---") or "stateDiagram-v2" in text
    for edge in ("LOOK --> PICK_PLACE: found", "PICK_PLACE --> LOOK: placed", "PICK_PLACE --> CLEAR_VIEW: missed",
                 "CLEAR_VIEW --> LOOK: view_clear", "LOOK --> DONE: clear", "LOOK --> FAILED: exhausted",
                 "PICK_PLACE --> FAILED: stuck"):
        assert edge in text, text


def test_sort_and_vision_types_do_not_import_pybullet_or_cv2() -> None:
    code = ("import sys, robokit_behaviours.sort, robokit.msgs.vision; "
            "print('pybullet' in sys.modules, 'cv2' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stdout.strip() == "False False", proc.stderr
