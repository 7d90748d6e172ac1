"""A wall-clock budget per plugin call for the conformance checks: a call that never returns fails the check.

The work (building a simulation, stepping it) runs in a daemon thread that reports, before each plugin call, what
it is about to do (a "beat"). The checking thread waits; when one call has taken longer than the budget it gives
up, names the call, and abandons the worker: the thread is asked to stop (an exception raised in it at its next
Python instruction, through the C API's public ``PyThreadState_SetAsyncExc``) and, being a daemon, can never keep
the process alive. A call stuck inside C code is left to finish on its own; its simulation is then not closed, so
nothing touches the physics engine from two threads.

The watchdog reads ``time.monotonic`` as it was when this module was imported: the behaviour check replaces the
``time`` functions to prove a behaviour ignores the wall clock, and the budget must not be fooled by that.
"""

from __future__ import annotations

import ctypes
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")

DEFAULT_BUDGET = 10.0
"""Wall-clock seconds one plugin call (a build, one tick, a close) may take in a conformance check."""

_clock = time.monotonic  # the real clock, kept before any check replaces time.monotonic


class Abandoned(BaseException):
    """Raised inside a worker thread that overran its budget, to stop it (never seen by the checking thread)."""


class Overrun(Exception):
    """A call took longer than its budget. ``what`` names the call."""

    def __init__(self, what: str, budget: float) -> None:
        super().__init__(f"{what} did not return within its wall-clock budget of {budget:g} s")
        self.what, self.budget = what, budget


class Beat:
    """What the worker is doing now and since when (read by the checking thread)."""

    def __init__(self) -> None:
        self.what = "starting"
        self.since = _clock()

    def __call__(self, what: str) -> None:
        """The worker is about to make the call ``what`` (e.g. ``"step() at tick 12"``)."""
        self.what, self.since = what, _clock()


def run_bounded(work: Callable[[Beat], T], budget: float = DEFAULT_BUDGET, poll: float = 0.02) -> T:
    """Run ``work(beat)`` in a daemon thread; return its result or re-raise what it raised.

    Raises:
        Overrun: One call (between two beats) took longer than ``budget`` wall-clock seconds; the worker is
            abandoned.
    """
    beat = Beat()
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = work(beat)
        except Abandoned:
            box["abandoned"] = True
        except BaseException as exc:  # noqa: BLE001 - handed to the checking thread
            box["error"] = exc

    worker = threading.Thread(target=target, name="robokit-check", daemon=True)
    worker.start()
    while True:
        worker.join(poll)
        if not worker.is_alive():
            break
        if _clock() - beat.since > budget:
            _abandon(worker)
            raise Overrun(beat.what, budget)
    if "error" in box:
        raise box["error"]
    return box["value"]  # type: ignore[no-any-return]


def _abandon(worker: threading.Thread) -> None:
    """Ask a runaway worker to stop (at its next Python instruction) and give it a moment to."""
    if worker.ident is not None:
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(worker.ident), ctypes.py_object(Abandoned))
    worker.join(1.0)
