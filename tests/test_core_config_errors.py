"""A corpus of broken configs: each one gives a single line naming the file and the key, exit code 2, no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main

CORPUS = sorted((Path(__file__).parent / "broken_configs").glob("*.toml"))


def _expected(path: Path) -> str:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# expect: "), f"{path.name} must start with '# expect: <key>'"
    return first[len("# expect: ") :].strip()


def test_corpus_is_large_enough() -> None:
    assert len(CORPUS) >= 20


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_broken_config_gives_one_line_and_exit_2(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["validate", str(path)])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(path) in lines[0]
    assert _expected(path) in lines[0]
    assert "Traceback" not in err


def test_unknown_key_suggests_the_close_one(capsys: pytest.CaptureFixture[str]) -> None:
    main(["validate", str(Path(__file__).parent / "broken_configs" / "unknown_world_key.toml")])
    err = capsys.readouterr().err
    assert "did you mean 'gravity'" in err


def test_unknown_joint_lists_the_valid_joints(capsys: pytest.CaptureFixture[str]) -> None:
    main(["validate", str(Path(__file__).parent / "broken_configs" / "unknown_joint.toml")])
    err = capsys.readouterr().err
    assert "head_swivel" in err and "valid:" in err


def test_config_error_through_the_console_script_has_no_traceback() -> None:
    path = Path(__file__).parent / "broken_configs" / "negative_mass.toml"
    proc = subprocess.run(
        [sys.executable, "-m", "robokit.cli", "run", str(path)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip().count("\n") == 0
    assert "bodies.box.mass" in proc.stderr and "greater than or equal to 0" in proc.stderr


def test_missing_config_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", "no/such/config.toml"]) == 2
    assert "no/such/config.toml: file not found" in capsys.readouterr().err
