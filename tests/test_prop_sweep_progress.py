"""The sweep's progress display against docs/sweeps.md's promises, over generated sweeps.

docs/sweeps.md: a live bar on a terminal (done/total, trials that did not succeed, trials per second, ETA), one plain
line every few trials otherwise (``sweep: 20/100 done, 0 not succeeded, 1.42 trials/s, ETA 56 s``); the rate counts
from when the first trial began running, so the workers' start-up is not in it; the very first line shows no rate
(``ETA ?``). Each property feeds generated finished trials (outcomes, run times, clock steps; resumed or not) to the
display and reads what a person would see, judged by a plain tally kept by the test: every figure of every line, the
lines' spacing, the last line at the end, nothing shown without a stream, and the bar's counts on a terminal.
"""

from __future__ import annotations

import io
import math
import re

from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.sweep import progress

OUTCOMES = ("succeeded", "failed", "timeout", "error", "interrupted")


class HandClock:
    """The display's ``time`` module: a clock the test moves by hand (the figures are sim-free wall time)."""

    def __init__(self, now: float) -> None:
        self.now = now

    def monotonic(self) -> float:
        return self.now


class Terminal(io.StringIO):
    """A stream that says it is a terminal, so the display draws its bar into it."""

    def isatty(self) -> bool:
        return True


@st.composite
def sweeps(draw: st.DrawFn) -> tuple[int, int, int, list[tuple[float, str, float]]]:
    """(total, already done, of those not succeeded, finished trials as (clock step, outcome, the trial's run time))."""
    total = draw(st.integers(1, 90))
    done = draw(st.integers(0, total - 1))
    failed = draw(st.integers(0, done))
    trials = draw(st.lists(st.tuples(st.sampled_from([0.0, 0.25, 0.5, 1.0, 2.0, 3.5, 7.0]),
                                     st.sampled_from(OUTCOMES),
                                     st.sampled_from([0.0, 0.5, 1.0, 2.0, 4.0, 30.0])),
                           min_size=total - done, max_size=total - done))
    return total, done, failed, trials


def expected_lines(total: int, done: int, failed: int, start: float,
                   trials: list[tuple[float, str, float]]) -> list[str]:
    """The plain lines docs/sweeps.md describes, computed by the test: one every max(1, left // 20) trials and at
    the end; the rate over the time since the earliest finished trial began (never before the display started)."""
    lines = [f"sweep: {done}/{total} trials already done, resuming"] if done else []
    every = max(1, (total - done) // 20)
    first_done, now, began = done, start, math.inf
    for step, outcome, ran_for in trials:
        now += step
        done += 1
        failed += outcome != "succeeded"
        began = min(began, max(start, now - ran_for))
        if (done - first_done) % every and done != total:
            continue
        head = f"sweep: {done}/{total} done, {failed} not succeeded"
        finished_here, elapsed = done - first_done, now - began
        if finished_here < 2 or elapsed <= 0:
            lines.append(head + (", ETA ?" if done < total else ""))
        else:
            rate = finished_here / elapsed
            lines.append(f"{head}, {rate:.2f} trials/s, ETA {(total - done) / rate:.0f} s")
    return lines


@settings(max_examples=60, deadline=None)
@given(sweep=sweeps(), start=st.sampled_from([0.0, 5.0, 1234.5]))
def test_every_plain_line_and_its_figures(sweep: tuple[int, int, int, list[tuple[float, str, float]]],
                                          start: float) -> None:
    total, done, failed, trials = sweep
    clock = HandClock(start)
    saved = progress.time
    progress.time = clock  # type: ignore[assignment]
    try:
        out = io.StringIO()
        shown = progress.Progress(total=total, done=done, failed=failed, stream=out)
        for step, outcome, ran_for in trials:
            clock.now += step
            shown.update({"outcome": outcome, "wall_time": ran_for})
        shown.close()
    finally:
        progress.time = saved
    assert out.getvalue().splitlines() == expected_lines(total, done, failed, start, trials)
    assert out.getvalue().endswith("\n")
    # the display's own counters equal the tally too (the sweep's summary reads them)
    assert (shown.done, shown.failed) == (total, failed + sum(o != "succeeded" for _, o, _ in trials))


@settings(max_examples=25, deadline=None)
@given(sweep=sweeps())
def test_nothing_is_shown_without_a_stream(sweep: tuple[int, int, int, list[tuple[float, str, float]]]) -> None:
    total, done, failed, trials = sweep
    shown = progress.Progress(total=total, done=done, failed=failed, stream=None)
    for _step, outcome, ran_for in trials:
        shown.update({"outcome": outcome, "wall_time": ran_for})
    shown.close()
    assert shown.bar is None
    assert (shown.done, shown.failed) == (total, failed + sum(o != "succeeded" for _, o, _ in trials))


BAR_COUNT = re.compile(r"(\d+)/(\d+)")
BAR_FAILED = re.compile(r"not succeeded (\d+)")


@settings(max_examples=20, deadline=None)
@given(sweep=sweeps())
def test_a_terminal_gets_a_bar_with_the_counts(sweep: tuple[int, int, int, list[tuple[float, str, float]]]) -> None:
    total, done, failed, trials = sweep
    out = Terminal()
    shown = progress.Progress(total=total, done=done, failed=failed, stream=out)
    frames = [f for f in re.split(r"[\r\n]", out.getvalue()) if f.strip()]
    assert frames, "a terminal sees the bar at once"
    assert "resuming" not in out.getvalue()  # the plain resume line is for logs; the bar starts at `done` itself
    first = frames[-1]
    assert first.startswith("sweep")
    assert BAR_COUNT.search(first).groups() == (str(done), str(total))  # type: ignore[union-attr]
    assert BAR_FAILED.search(first).group(1) == str(failed)  # type: ignore[union-attr]
    not_succeeded = failed
    for _step, outcome, ran_for in trials:
        not_succeeded += outcome != "succeeded"
        shown.update({"outcome": outcome, "wall_time": ran_for})
    shown.close()
    last = [f for f in re.split(r"[\r\n]", out.getvalue()) if f.strip()][-1]
    assert BAR_COUNT.search(last).groups() == (str(total), str(total))  # type: ignore[union-attr]
    assert BAR_FAILED.search(last).group(1) == str(not_succeeded)  # type: ignore[union-attr]
    assert "trial" in last  # the unit a person reads the rate in
    assert "done," not in out.getvalue()  # no plain lines drawn over the bar
