"""Charts for the learning dashboard, drawn on the server with matplotlib (Agg) as SVG.

Text is written into the SVG as outlines (``svg.fonttype = "path"``) from a Korean font registered by file
(:mod:`robokit.record.fonts`: Noto Sans KR from ``robokit[server]``, else a system Korean font), so a chart reads
the same in any browser, with or without Korean fonts on the teacher's machine, and on a server whose matplotlib
font cache predates its fonts. The SVG is made here from numbers and names, never from an upload, and is served
with the pages' CSP.
"""

from __future__ import annotations

import io
import textwrap
import threading
from collections.abc import Sequence
from datetime import datetime, timedelta
from typing import Any

from robokit.record.fonts import korean_font, quiet_missing_glyphs

KOREAN_FONTS = ["NanumGothic", "Noto Sans CJK KR", "Noto Sans KR", "Malgun Gothic", "AppleGothic", "DejaVu Sans"]
BLUE, GREEN, RED, GREY = "#4c72b0", "#55a868", "#c44e52", "#8c8c8c"


def _integer_ticks() -> Any:
    from matplotlib.ticker import MaxNLocator

    return MaxNLocator(integer=True)


_SETUP = threading.Lock()
_configured = False


def _configure() -> None:
    """Set matplotlib's fonts and SVG options once per process, under a lock (requests arrive on many threads)."""
    global _configured
    with _SETUP:
        if _configured:
            return
        import matplotlib

        family = korean_font()
        matplotlib.rcParams.update({"font.family": "sans-serif",
                                    "font.sans-serif": [*([family] if family else []), *KOREAN_FONTS],
                                    "svg.fonttype": "path", "axes.unicode_minus": False, "svg.hashsalt": "robokit"})
        _configured = True


def _subplots(*args: Any, figsize: tuple[float, float], **kwargs: Any) -> tuple[Any, Any]:
    """A figure and its axes made without pyplot: pyplot keeps one global set of figures, which the server's request
    threads would share; a ``Figure`` of a request's own is never seen by another thread."""
    from matplotlib.figure import Figure

    _configure()
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*args, **kwargs)


def _svg(fig: Any) -> bytes:
    buf = io.BytesIO()
    with quiet_missing_glyphs():
        fig.tight_layout()
        fig.savefig(buf, format="svg", metadata={"Date": None})
    return buf.getvalue()


def _empty(ax: Any, text: str) -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color=GREY)
    ax.set_xticks([])
    ax.set_yticks([])


def _percent_axis(ax: Any, label: str) -> None:
    """0-100 % with room above 100 for the legend (so it never hides a point at 100 %)."""
    ax.set_ylim(-5, 135)
    ax.set_yticks([0, 20, 40, 60, 80, 100])
    ax.set_ylabel(label)
    ax.legend(loc="upper center", fontsize=8, ncol=2, frameon=False)


def _time_axis(ax: Any, times: Sequence[datetime]) -> None:
    """Dates on the x axis, at least a day wide (a single moment would otherwise span years)."""
    import matplotlib.dates as mdates

    first, last = min(times), max(times)
    pad = max((last - first) * 0.05, timedelta(hours=12)) if last - first < timedelta(days=1) else (
        (last - first) * 0.05)
    ax.set_xlim(first - pad, last + pad)
    locator = mdates.AutoDateLocator()
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))


def timeline(title: str, attempts: Sequence[datetime], official: Sequence[tuple[datetime, float]]) -> bytes:
    """A student's attempts (runs posted, grey ticks) and official results (success rate, blue dots) over time."""
    fig, ax = _subplots(figsize=(7.5, 2.8))
    if not attempts and not official:
        _empty(ax, "아직 기록이 없습니다 (no attempts yet)")
    else:
        if attempts:
            ax.scatter(list(attempts), [0.02] * len(attempts), marker="|", s=200, color=GREY, label="시도 attempts")
        if official:
            ax.plot([t for t, _ in official], [100 * v for _, v in official], "o-", color=BLUE, markersize=8,
                    label="공식 성공률 official success %")
        _time_axis(ax, [*attempts, *(t for t, _ in official)])
        _percent_axis(ax, "성공률 success %")
    ax.set_title(title)
    return _svg(fig)


def weekly(title: str, weeks: Sequence[str], rates: Sequence[float | None], counts: Sequence[int],
           official: Sequence[float | None] = ()) -> bytes:
    """Per week: the success rate of the student's own runs (green bars, the number of runs on each) and the
    best official success rate evaluated that week (blue dots)."""
    fig, ax = _subplots(figsize=(7.5, 2.8))
    if not weeks:
        _empty(ax, "아직 기록이 없습니다 (no runs yet)")
    else:
        x = range(len(weeks))
        bars = ax.bar(x, [100 * (r or 0.0) for r in rates], color=GREEN, width=0.6, label="내 실행 my runs")
        for bar, n in zip(bars, counts, strict=True):
            ax.annotate(f"{n}회", (bar.get_x() + bar.get_width() / 2, bar.get_height()), ha="center",
                        va="bottom", fontsize=8)
        marks = [(i, 100 * v) for i, v in zip(x, official, strict=False) if v is not None]
        if marks:
            ax.plot(*zip(*marks, strict=True), "o", color=BLUE, markersize=8, label="최고 공식 best official")
        ax.set_xticks(list(x), list(weeks), fontsize=8)
        ax.set_xlim(-0.8, max(len(weeks), 3) - 0.2)
        _percent_axis(ax, "주간 성공률 weekly success %")
    ax.set_title(title)
    return _svg(fig)


def distribution(title: str, values: Sequence[float], xlabel: str) -> bytes:
    """A histogram of the students' best official success rates (in %)."""
    fig, ax = _subplots(figsize=(6.5, 2.8))
    if not values:
        _empty(ax, "아직 공식 결과가 없습니다 (no official results yet)")
    else:
        ax.hist([100 * v for v in values], bins=[0, 10, 20, 30, 40, 50, 60, 70, 80, 90, 100.001], color=BLUE,
                edgecolor="white")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("학생 수 students")
        ax.yaxis.set_major_locator(_integer_ticks())
        ax.set_xlim(0, 100)
    ax.set_title(title)
    return _svg(fig)


def reasons(title: str, counted: Sequence[tuple[str, int]]) -> bytes:
    """The most common failure reasons, as horizontal bars."""
    fig, ax = _subplots(figsize=(7.5, max(2.4, 0.6 * len(counted) + 1.2)))
    if not counted:
        _empty(ax, "실패가 없습니다 (no failures)")
    else:
        labels = [textwrap.fill(r if len(r) <= 90 else r[:89] + "…", 32) for r, _ in counted][::-1]
        ax.barh(range(len(counted)), [n for _, n in counted][::-1], color=RED)
        ax.set_yticks(range(len(counted)), labels, fontsize=9)
        ax.xaxis.set_major_locator(_integer_ticks())
        ax.set_xlabel("횟수 count")
    ax.set_title(title)
    return _svg(fig)


def training(title: str, runs: Sequence[tuple[str, Sequence[dict[str, float]]]]) -> bytes:
    """Training curves: return (left) and success rate (right) over environment steps, one line per run."""
    fig, (left, right) = _subplots(1, 2, figsize=(8.5, 2.9))
    if not runs:
        _empty(left, "학습 기록 없음 (no training runs)")
        _empty(right, "")
    for k, (name, points) in enumerate(runs):  # each line's SVG group is named (gid): return-0, success-0, ...
        steps = [p["steps"] for p in points]
        if any("return" in p for p in points):
            left.plot([s for s, p in zip(steps, points, strict=True) if "return" in p],
                      [p["return"] for p in points if "return" in p], label=name or "run", gid=f"return-{k}")
        if any("success_rate" in p for p in points):
            right.plot([s for s, p in zip(steps, points, strict=True) if "success_rate" in p],
                       [100 * p["success_rate"] for p in points if "success_rate" in p], label=name or "run",
                       gid=f"success-{k}")
    if runs:
        left.set_xlabel("스텝 steps")
        left.set_ylabel("보상 return")
        right.set_xlabel("스텝 steps")
        right.set_ylabel("성공률 success %")
        right.set_ylim(-5, 105)
        left.legend(fontsize=7)
    fig.suptitle(title)
    return _svg(fig)
