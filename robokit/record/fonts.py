"""A Korean font for matplotlib that does not depend on the system's font cache.

matplotlib lists the system's fonts once and caches the list: a font installed later stays invisible (Korean text
drawn as boxes, one warning per glyph) until the cache is rebuilt. Here the font *file* is registered with
``matplotlib.font_manager.fontManager.addfont``, which needs no cache. The file comes from, in order:

1. ``pylopdf-fonts-ko`` (Noto Sans KR, SIL Open Font License 1.1), installed with ``robokit[server]``;
2. a system font: NanumGothic (``fonts-nanum``), Noto Sans CJK (``fonts-noto-cjk``), Malgun Gothic, AppleGothic.

Without any, the server says so once when it starts (:func:`warn_if_no_korean_font`, or at the first chart:
:func:`korean_font`) and charts draw Korean as boxes; the per-glyph warnings matplotlib would give are silenced by
:func:`quiet_missing_glyphs`.
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Iterator
from pathlib import Path

log = logging.getLogger("robokit.fonts")
SYSTEM_FILES = (
    "/usr/share/fonts/truetype/nanum/NanumGothic.ttf",
    "/usr/share/fonts/opentype/noto/NotoSansCJK-Regular.ttc",
    "/usr/share/fonts/noto-cjk/NotoSansCJK-Regular.ttc",
    "/usr/share/fonts/google-noto-cjk/NotoSansCJK-Regular.ttc",
    "C:/Windows/Fonts/malgun.ttf",
    "/System/Library/Fonts/Supplemental/AppleGothic.ttf",
    "/Library/Fonts/AppleGothic.ttf",
)
MISSING = ("no Korean font found: charts draw Korean text as boxes. Install robokit's server extra "
           "(pip install 'robokit[server]', which brings Noto Sans KR) or a system font (apt install fonts-nanum)")
_found: list[str | None] = []
_warned: list[bool] = []


def korean_font_file() -> Path | None:
    """The first Korean font file found (the packaged one first); reads no font and imports no matplotlib."""
    try:
        import pylopdf_fonts_ko
    except ImportError:
        pass
    else:
        packaged = Path(pylopdf_fonts_ko.sans_path())
        if packaged.is_file():
            return packaged
    return next((Path(p) for p in SYSTEM_FILES if Path(p).is_file()), None)


def korean_font(*, warn: bool = True) -> str | None:
    """Register the Korean font file with matplotlib (once per process) and return its family name, for the
    front of ``font.sans-serif``; None when there is none, after one logged warning (``warn``: the course
    server's charts, whose titles are Korean; a run's plots only use the font when it is there)."""
    if _found:
        if _found[0] is None and warn and not _warned:
            _warned.append(True)
            log.warning("robokit: warning: %s", MISSING)
        return _found[0]
    from matplotlib import font_manager

    family = None
    path = korean_font_file()
    if path is not None:
        try:
            font_manager.fontManager.addfont(str(path))
            family = font_manager.FontProperties(fname=str(path)).get_name()
        except (OSError, RuntimeError, ValueError) as exc:
            log.warning("robokit: warning: the Korean font %s could not be read (%s)", path.name, exc)
    if family is None and warn and not _warned:
        _warned.append(True)
        log.warning("robokit: warning: %s", MISSING)
    _found.append(family)
    return family


def warn_if_no_korean_font() -> None:
    """At a server's start: the one warning, when no Korean font file is there (looks for files only, imports no
    matplotlib); charts drawn later do not repeat it."""
    if not _warned and korean_font_file() is None:
        _warned.append(True)
        log.warning("robokit: warning: %s", MISSING)


@contextlib.contextmanager
def quiet_missing_glyphs(*, warn: bool = True) -> Iterator[None]:
    """Without a Korean font, matplotlib warns once per glyph it cannot draw: the one warning of
    :func:`korean_font` says it already."""
    with warnings.catch_warnings():
        if korean_font(warn=warn) is None:
            warnings.filterwarnings("ignore", message=r"Glyph \d+ .* missing from")
        yield
