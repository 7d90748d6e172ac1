"""Where did my run go: ``robokit results list`` says which folder it read and where else in this checkout runs
were kept, its table lines up with Korean config names, ``results last --path`` gives a folder the shell can use,
and ``--save-frames`` ends with the line saying where the frames went."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main

SCENE = """
[world]
max_time = 0.05
seed = 4

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0, 0, 0.5]
"""


@pytest.fixture
def checkout(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A checkout of one's own: pyproject.toml at the root, a configs/ folder."""
    (tmp_path / "pyproject.toml").write_text("[project]\nname = 'mine'\n")
    (tmp_path / "configs").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _columns(line: str) -> int:
    """Terminal columns of ``line``: Hangul syllables take two."""
    return sum(2 if "\uac00" <= ch <= "\ud7a3" else 1 for ch in line)


def test_list_says_where_it_looked_and_finds_runs_started_from_configs(
        checkout: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    (checkout / "configs" / "scene.toml").write_text(SCENE)
    monkeypatch.chdir(checkout / "configs")
    assert main(["run", "scene.toml", "--quiet"]) == 0  # a student who ran from configs/
    assert (checkout / "configs" / "results").is_dir()
    monkeypatch.chdir(checkout)
    capsys.readouterr()
    assert main(["results", "list"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("no runs in results/")
    assert captured.err.splitlines() == [
        "(also 1 run(s) in configs/results/: robokit results list --dir configs/results)"]
    assert main(["results", "list", "--dir", "configs/results"]) == 0
    captured = capsys.readouterr()
    assert len(captured.out.splitlines()) == 2 and "scene.toml" in captured.out
    assert captured.err.splitlines()[0] == "(runs in configs/results/)"
    assert "also" not in captured.err  # the folder it read is not listed twice


def test_list_lines_up_korean_config_names(checkout: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("정렬로봇.toml", "a.toml"):
        (checkout / "configs" / name).write_text(SCENE)
        assert main(["run", f"configs/{name}", "--quiet"]) == 0
    capsys.readouterr()
    assert main(["results", "list"]) == 0
    header, *rows = capsys.readouterr().out.splitlines()
    assert len(rows) == 2 and any("정렬로봇" in row for row in rows)
    for column in ("seed", "outcome", "sim s"):
        at = _columns(header[:header.index(column)])
        for row in rows:
            before = next(i for i in range(len(row)) if _columns(row[:i]) == at)
            assert row[before - 2:before] == "  " and row[before] != " ", (column, row)


def test_results_last_path_is_the_newest_folder_and_frames_say_where_they_went(
        checkout: Path, capsys: pytest.CaptureFixture[str]) -> None:
    root = Path(__file__).resolve().parent.parent
    (checkout / "configs" / "camera_demo.toml").symlink_to(root / "configs" / "camera_demo.toml")
    assert main(["run", "configs/camera_demo.toml", "--save-frames", "--max-time", "0.3"]) == 1  # stopped early
    last = capsys.readouterr().out.splitlines()[-1]
    folder = next(p for p in (checkout / "results").iterdir())
    pngs = sorted((folder / "frames").glob("*.png"))
    assert pngs, "the camera saved no frame"
    assert last == f"frames: {len(pngs)} PNG(s) in results/{folder.name}/frames/"
    assert main(["results", "last", "--path"]) == 0
    printed = capsys.readouterr().out.strip()
    assert Path(printed).resolve() == folder.resolve()
    # the lesson's command, pasted into a shell as written
    listing = subprocess.run(["sh", "-c", f'ls "$({sys.executable} -m robokit.cli results last --path)/frames/"'],
                             capture_output=True, text=True, check=True).stdout.split()
    assert listing == [p.name for p in pngs]


def test_save_frames_without_a_record_says_none_were_kept(checkout: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (checkout / "configs" / "scene.toml").write_text(SCENE)
    assert main(["run", "configs/scene.toml", "--save-frames", "--no-record"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "frames: none saved (--no-record keeps no run folder for them)"
