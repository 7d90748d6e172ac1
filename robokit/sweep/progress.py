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
        if self.bar is not None:
            self.bar.set_postfix_str(f"not succeeded {self.failed}", refresh=False)
            self.bar.update(1)
        elif self.stream is not None and ((self.done - self.start_done) % self.every == 0 or self.done == self.total):
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def line(self) -> str:
        """``sweep: 40/120 done, 3 not succeeded, 2.10 trials/s, ETA 38 s``."""
        elapsed = time.monotonic() - self.t0
        ran = self.done - self.start_done
        rate = ran / elapsed if elapsed > 0 else 0.0
        eta = f"{(self.total - self.done) / rate:.0f} s" if rate > 0 else "?"
        return (f"sweep: {self.done}/{self.total} done, {self.failed} not succeeded, {rate:.2f} trials/s, "
                f"ETA {eta}")

    def close(self) -> None:
        """End the bar (the plain mode has nothing to close)."""
        if self.bar is not None:
            self.bar.close()
