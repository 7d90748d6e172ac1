"""The bad-input corpus (``bad_input_corpus.py``): every case is refused by ``robokit validate`` with exit 2, exactly
one line on stderr naming the file and the key, and no traceback.

The bulk runs in-process through ``robokit.cli.main`` (the code path the command runs); a sample runs the real
command in a fresh process, where a traceback would really reach the terminal.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from bad_input_corpus import CASES

from robokit.cli import main


def test_the_corpus_is_large_and_covers_every_section_and_built_in_type() -> None:
    from robokit.plugin_api.plugins import load_plugins

    SECTIONS = ("world", "regions", "bodies", "robots", "sensors", "actuators", "behaviour", "report", "events",
                "record", "gui")  # the README's config reference ([env] belongs to robokit.gym's own tests)

    assert len(CASES) >= 60
    text = "\n".join(case.toml for case in CASES.values())
    for section in SECTIONS:
        assert f"[{section}" in text or f"[[{section}" in text or f"{section} =" in text, section
    for ptype in load_plugins().all_types():
        if ptype.kind == "task":  # tasks live in [env], which robokit.gym's own tests cover
            continue
        named = f'type = "{ptype.name}"' in text or f"[report.{ptype.name}]" in text
        assert named, f"no corpus case uses {ptype.kind} type {ptype.name!r}"


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_config_is_one_line_naming_the_key(name: str, tmp_path: Path, capsys, monkeypatch) -> None:
    case = CASES[name]
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "bad.toml"
    path.write_text(case.toml)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    prefix = f"robokit: error: {path}: {case.key}"
    assert lines[0].startswith(prefix), lines[0]
    assert case.fragment in lines[0], lines[0]


SAMPLE = ["world max_time absurd", "body missing urdf", "lidar unknown link", "http url port out of range",
          "event force inf", "behaviour unknown type"]


@pytest.mark.slow
@pytest.mark.parametrize("name", SAMPLE)
def test_the_real_command_refuses_a_sample(name: str, tmp_path: Path) -> None:
    case = CASES[name]
    (tmp_path / "bad.toml").write_text(case.toml)
    for command in ("validate", "run"):
        proc = subprocess.run([sys.executable, "-m", "robokit.cli", command, "bad.toml"], cwd=tmp_path,
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.startswith(f"robokit: error: bad.toml: {case.key}") and proc.stderr.count("\n") == 1
        assert case.fragment in proc.stderr and proc.stdout == ""
        assert not list(tmp_path.rglob("result.json"))  # nothing ran, nothing was stored
