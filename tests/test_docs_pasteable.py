"""Text a student pastes or trusts: shell blocks in README.md and every page under docs/ (lessons in both languages
included) hold no ``<placeholder>`` a shell would choke on, the configs' comments say where results really go, and
the error lines docs/configs.md shows are what robokit prints."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
SHELL = ("```sh", "```bash", "```shell", "```console")
_PLACEHOLDER = re.compile(r"<[^<>\s][^<>]*>")


def _shell_lines(path: Path) -> list[tuple[int, str]]:
    """``(line number, command part)`` of every line in a shell block (comments after `` #`` dropped)."""
    out, fence = [], None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.strip().startswith("```"):
            fence = None if fence else line.strip()
            continue
        if fence in SHELL and not line.lstrip().startswith("#"):
            out.append((n, re.split(r"\s#", line, maxsplit=1)[0]))
    return out


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_shell_blocks_have_no_placeholders(doc: Path) -> None:
    for n, code in _shell_lines(doc):
        assert not _PLACEHOLDER.search(code), (f"{doc.relative_to(ROOT)}:{n}: {code.strip()!r} cannot be pasted; "
                                               "compute the value, e.g. \"$(robokit results last --path)\"")


def test_the_lessons_in_both_languages_are_checked() -> None:
    names = {p.name for p in DOCS}
    assert {"05-cameras.md", "05-cameras.ko.md"} <= names


@pytest.mark.parametrize("config", sorted((ROOT / "configs").rglob("*.toml")), ids=lambda p: p.name)
def test_config_comments_name_the_run_folder_layout(config: Path) -> None:
    """The local reporter keeps ``results/<run id>/result.json`` (a folder per run), never ``results/<id>.json``."""
    for n, line in enumerate(config.read_text(encoding="utf-8").splitlines(), 1):
        if line.lstrip().startswith("#") and "results/<run" in line:
            assert not re.search(r"results/<run[ _]id>\.json", line), f"{config.name}:{n}: {line.strip()}"


def test_the_config_guide_error_lines_are_what_validate_prints(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """docs/configs.md shows two error lines for ``configs/x.toml``: a negative mass and a misspelt key.
    Both configs are written here and validated; the lines must be what robokit prints (``...`` ends a cut)."""
    from robokit.cli import main

    shown = [line for line in (ROOT / "docs" / "configs.md").read_text(encoding="utf-8").splitlines()
             if line.startswith("robokit: error: configs/x.toml:")]
    assert len(shown) == 2
    (tmp_path / "configs").mkdir()
    monkeypatch.chdir(tmp_path)
    box = '[bodies.box]\nshape = "box"\nposition = [0, 0, 0.5]\n'
    printed = []
    for config in (box + "mass = -1.0\n", "[world]\ngravty = [0, 0, -9.81]\n\n" + box):
        (tmp_path / "configs" / "x.toml").write_text(config)
        assert main(["validate", "configs/x.toml"]) == 2
        printed.append(capsys.readouterr().err.strip())
    for line, real in zip(shown, printed, strict=True):
        if line.endswith("..."):
            assert real.startswith(line[:-3]), (line, real)
        else:
            assert real == line
