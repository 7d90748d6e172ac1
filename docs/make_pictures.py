"""Make the lessons' pictures from the commands their pages show, so a page always shows what its commands make.

For each lesson page whose shell block writes its own picture (``robokit video last --time ... -o NN-name.png``),
this runs the block's ``robokit run`` line(s) and that picture line, exactly as written, in a scratch folder whose
``configs`` is the repository's, and copies the picture into ``docs/lessons/``::

    python docs/make_pictures.py              # every such lesson
    python docs/make_pictures.py 01 04        # some of them
    python docs/make_pictures.py --check 01   # make them in the scratch folder and compare with the pages' own

``--check`` compares a 64x48 downscale of each picture (mean absolute difference per channel, 0-255) and exits 1
when one differs by more than :data:`TOLERANCE` (the still is deterministic; the margin absorbs PNG and font
rasteriser versions).
"""

from __future__ import annotations

import argparse
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LESSONS = ROOT / "docs" / "lessons"
TOLERANCE = 2.0
"""Largest mean absolute difference (per channel, 0-255) between a 64x48 downscale of a made and a kept picture."""
ROBOKIT = [sys.executable, "-c", "import sys; from robokit.cli import main; sys.exit(main())"]


@dataclass(frozen=True)
class Lesson:
    """A lesson page, the commands of its shell block that make its picture, and the picture's file name."""

    page: Path
    commands: list[list[str]]
    picture: str


def lesson_of(page: Path) -> Lesson | None:
    """The page's first ``sh`` block: its ``robokit run`` lines and the line writing ``<page stem>.png``."""
    block = re.search(r"```sh\n(.*?)```", page.read_text(encoding="utf-8"), re.S)
    if block is None:
        return None
    picture = f"{page.stem}.png"
    commands = []
    for line in block.group(1).splitlines():
        argv = shlex.split(line, comments=True)
        if argv[:2] == ["robokit", "run"] or (argv[:1] == ["robokit"] and picture in argv):
            commands.append(argv[1:])
    if not any(picture in argv for argv in commands):
        return None
    return Lesson(page, commands, picture)


def lessons(prefixes: list[str]) -> list[Lesson]:
    """The lessons (English pages) whose picture a command makes, those starting with one of ``prefixes``."""
    pages = sorted(p for p in LESSONS.glob("[0-9][0-9]-*.md") if not p.name.endswith(".ko.md"))
    found = [lesson_of(p) for p in pages if not prefixes or any(p.name.startswith(x) for x in prefixes)]
    return [lesson for lesson in found if lesson is not None]


def make(lesson: Lesson, scratch: Path) -> Path:
    """Run the lesson's commands in ``scratch`` (its ``configs`` is the repository's); the picture made there."""
    scratch.mkdir(parents=True, exist_ok=True)
    if not (scratch / "configs").exists():
        (scratch / "configs").symlink_to(ROOT / "configs")
    for argv in lesson.commands:
        done = subprocess.run(ROBOKIT + argv, cwd=scratch, capture_output=True, text=True)
        if done.returncode not in (0, 1):  # 1: a behaviour that fails is still a picture worth showing
            raise RuntimeError(f"{lesson.page.name}: robokit {shlex.join(argv)} exited {done.returncode}: "
                               f"{done.stderr.strip()[-500:]}")
    return scratch / lesson.picture


def difference(a: Path, b: Path) -> float:
    """Mean absolute difference (0-255) of 64x48 downscales of two pictures (area averaging)."""
    import cv2
    import numpy as np

    small = []
    for path in (a, b):
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise RuntimeError(f"{path}: not a picture")
        small.append(cv2.resize(image, (64, 48), interpolation=cv2.INTER_AREA))
    return float(np.abs(small[0].astype(np.float64) - small[1].astype(np.float64)).mean())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("lessons", nargs="*", help="lesson number prefixes (default: every lesson with a picture)")
    parser.add_argument("--check", action="store_true", help="compare with the pages' pictures; write nothing")
    args = parser.parse_args(argv)
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for lesson in lessons(args.lessons):
            made = make(lesson, Path(tmp) / lesson.page.stem)
            kept = LESSONS / lesson.picture
            if args.check:
                diff = difference(made, kept) if kept.is_file() else float("inf")
                worst = max(worst, diff)
                print(f"{kept.relative_to(ROOT)}: differs by {diff:.2f} (tolerance {TOLERANCE})")
            else:
                shutil.copyfile(made, kept)
                shown = '; '.join('robokit ' + shlex.join(c) for c in lesson.commands)
                print(f"{kept.relative_to(ROOT)}: made by {shown}")
    return 1 if args.check and worst > TOLERANCE else 0


if __name__ == "__main__":
    sys.exit(main())
