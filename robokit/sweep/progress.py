"""Progress of a sweep: a live tqdm bar on a terminal, one plain line every few trials otherwise (logs, CI)."""

from __future__ import annotations

import time
from typing import IO, Any


class Progress:
    """Counts finished trials and shows done/total, trials not succeeded, trials per second and the ETA.

    Args:
        total: Trials in the sweep.
        done: Trials already finished (resumed sweeps start there).
        failed: Of those, how many did not succeed.
        stream: Where to write; None shows nothing. A terminal gets a tqdm bar, anything else plain lines.
    """

    def __init__(self, total: int, done: int, failed: int, stream: IO[str] | None) -> None:
        self.total, self.done, self.failed = total, done, failed
        self.stream = stream
        self.start_done = done
        self.t0 = time.monotonic()  # display only: rates and ETA shown to people
        self.began: float | None = None  # when the earliest trial finished so far began running
        self.every = max(1, (total - done) // 20)
        self.bar: Any = None
        if stream is not None and stream.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, file=stream, unit="trial", dynamic_ncols=True,
                            desc="sweep")
            self.bar.set_postfix_str(f"not succeeded {failed}")
        elif stream is not None and done:
            stream.write(f"sweep: {done}/{total} trials already done, resuming\n")
            stream.flush()

    def update(self, row: dict[str, Any]) -> None:
        """Count one finished trial."""
        self.done += 1
        self.failed += row["outcome"] != "succeeded"
        began = max(self.t0, time.monotonic() - float(row.get("wall_time") or 0.0))
        self.began = began if self.began is None else min(self.began, began)
        if self.bar is not None:
            self.bar.set_postfix_str(f"not succeeded {self.failed}", refresh=False)
            self.bar.update(1)
        elif self.stream is not None and ((self.done - self.start_done) % self.every == 0 or self.done == self.total):
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def line(self) -> str:
        """``sweep: 40/120 done, 3 not succeeded, 2.10 trials/s, ETA 38 s``.

        The rate counts from when the first trial began running, not from the start of the sweep: starting the
        workers (seconds of imports) is no part of it, or the first line after a resume, printed after one trial,
        would show the start-up as the rate. One finished trial cannot tell a rate when several workers run, so
        the first line shows none.
        """
        head = f"sweep: {self.done}/{self.total} done, {self.failed} not succeeded"
        ran = self.done - self.start_done
        elapsed = time.monotonic() - (self.t0 if self.began is None else self.began)
        if ran < 2 or elapsed <= 0:
            return head + (", ETA ?" if self.done < self.total else "")
        rate = ran / elapsed
        return f"{head}, {rate:.2f} trials/s, ETA {(self.total - self.done) / rate:.0f} s"

    def close(self) -> None:
        """End the bar (the plain mode has nothing to close)."""
        if self.bar is not None:
            self.bar.close()
