"""The lessons' pictures are what their pages' commands make (``docs/make_pictures.py``), compared on a 64x48
downscale; the comparison itself tells a different camera view apart."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _script():  # noqa: ANN202 - the module loaded from docs/
    spec = importlib.util.spec_from_file_location("make_pictures", ROOT / "docs" / "make_pictures.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_pictures", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_the_pages_that_picture_a_still_are_found_with_their_commands() -> None:
    found = {lesson.page.name: lesson for lesson in _script().lessons([])}
    assert {"01-physics-world.md", "04-contacts-rays.md", "06-pick-place.md", "08-projects.md"} <= set(found)
    assert found["04-contacts-rays.md"].commands == [
        ["run", "configs/contact_stop.toml"],
        ["video", "last", "--time", "end", "--size", "480x360", "-o", "04-contacts-rays.png"]]


@pytest.mark.slow
def test_lesson_04_s_picture_is_what_its_commands_make(tmp_path: Path) -> None:
    script = _script()
    [lesson] = script.lessons(["04"])
    made = script.make(lesson, tmp_path / "scratch")
    kept = ROOT / "docs" / "lessons" / lesson.picture
    assert script.difference(made, kept) <= script.TOLERANCE


@pytest.mark.slow
def test_the_comparison_tells_another_camera_view_apart(tmp_path: Path) -> None:
    script = _script()
    [lesson] = script.lessons(["04"])
    script.make(lesson, tmp_path / "scratch")
    kept = ROOT / "docs" / "lessons" / lesson.picture
    other = tmp_path / "scratch" / "front.png"  # the same moment from another camera: the check must see it
    done = subprocess.run(script.ROBOKIT + ["video", "last", "--time", "end", "--size", "480x360", "--view", "front",
                                            "-o", str(other)], cwd=tmp_path / "scratch", capture_output=True)
    assert done.returncode == 0, done.stderr
    assert script.difference(other, kept) > 5 * script.TOLERANCE


@pytest.mark.slow
def test_every_lesson_picture_is_what_its_commands_make() -> None:
    assert _script().main(["--check"]) == 0
