"""Ctrl-C, SIGTERM and the wall-clock budget: stop promptly, keep the result.

One :class:`StopGuard` handles SIGINT and SIGTERM for a whole command (start-up, the physics loop, delivery):

- **outside the loop** a signal raises :class:`~robokit.errors.Interrupted` at once (start-up stops, a delivery
  waiting on a slow server stops; what was already stored stays stored);
- **inside the loop** (:meth:`StopGuard.soft`) the first signal asks the loop to stop at the next tick boundary;
  if the loop has not stopped ``grace`` seconds later (a plugin stuck in a slow call), ``Interrupted`` is raised
  in the main thread wherever it is. A second signal raises at once.

The wall-clock budget (``--max-wall``, ``[world] max_wall_time``) is a watchdog thread that does the same when the
budget runs out: ask the loop to stop, then break out of a call that does not return. This is the one place robokit
looks at the wall clock for anything but GUI pacing: it is a watchdog, not logic.

Signals can only be handled in the main thread; elsewhere (a worker thread) the guard is inert and the loop just
stops at tick boundaries when asked.
"""

from __future__ import annotations

import _thread
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

from robokit.errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)
GRACE = 0.5
"""Seconds the loop gets to reach a tick boundary after a stop request before it is broken out of."""


class StopGuard:
    """SIGINT/SIGTERM handling for one command. Use as a context manager (installs and restores the handlers).

    Attributes:
        signal: Name of the first signal received (``"SIGINT"``, ``"SIGTERM"``), or None.
    """

    def __init__(self, grace: float = GRACE) -> None:
        self.grace = grace
        self.signal: str | None = None
        self.installed = False
        self._old: dict[int, Any] = {}
        self._soft_stop: Callable[[str], None] | None = None
        self._force_reason: str | None = None
        self._timers: list[threading.Timer] = []

    # ----------------------------------------------------------------- installing
    @classmethod
    def current(cls) -> StopGuard | None:
        """The guard whose handler is installed for SIGINT, if any."""
        owner = getattr(signal.getsignal(signal.SIGINT), "__self__", None)
        return owner if isinstance(owner, StopGuard) else None

    @classmethod
    @contextmanager
    def ensure(cls) -> Iterator[StopGuard]:
        """The installed guard, or a new one installed for the duration (inert outside the main thread)."""
        current = cls.current()
        if current is not None:
            yield current
            return
        with cls() as guard:
            yield guard

    def __enter__(self) -> StopGuard:
        if threading.current_thread() is threading.main_thread():
            self._old = {s: signal.signal(s, self._handle) for s in SIGNALS}
            self.installed = True
        return self

    def __exit__(self, *exc: object) -> None:
        self._cancel_timers()
        if self.installed:
            for s, handler in self._old.items():
                signal.signal(s, handler)
            self.installed = False

    # ----------------------------------------------------------------- handling
    @property
    def signalled(self) -> bool:
        """A signal was received."""
        return self.signal is not None

    def _handle(self, signum: int, _frame: FrameType | None) -> None:
        if self._force_reason is not None:  # our own timer asks to break out of a call that does not return
            reason, self._force_reason = self._force_reason, None
            if self._soft_stop is not None:  # still in the loop (else it ended meanwhile: nothing to break)
                raise Interrupted(reason)
            return
        name = signal.Signals(signum).name
        first = self.signal is None
        if first:
            self.signal = name
        if first and self._soft_stop is not None:
            self._soft_stop(name)
            self.force_after(self.grace, name)
            return
        raise Interrupted(name)

    @contextmanager
    def soft(self, stop: Callable[[str], None]) -> Iterator[None]:
        """The physics loop: a signal calls ``stop(signal_name)`` instead of raising (see the module docstring)."""
        self._soft_stop = stop
        try:
            yield
        finally:
            self._soft_stop = None
            self._force_reason = None
            self._cancel_timers()

    def force_after(self, seconds: float, reason: str) -> None:
        """Raise ``Interrupted(reason)`` in the main thread after ``seconds`` unless the loop ended by then."""
        if not self.installed:
            return

        def fire() -> None:
            if self._soft_stop is None:
                return
            self._force_reason = reason
            _wake_main_thread()  # runs _handle in the main thread, which re-checks

        self._start_timer(seconds, fire)

    def watchdog(self, seconds: float, on_expire: Callable[[], None], reason: str) -> None:
        """After ``seconds``: call ``on_expire()`` (from the watchdog thread: it should only set a flag), then
        break out with ``Interrupted(reason)`` if the loop has not stopped ``grace`` seconds later."""

        def fire() -> None:
            if self._soft_stop is None:
                return
            on_expire()
            self.force_after(self.grace, reason)

        self._start_timer(seconds, fire)

    def _start_timer(self, seconds: float, fn: Callable[[], None]) -> None:
        timer = threading.Timer(seconds, fn)
        timer.daemon = True
        self._timers.append(timer)
        timer.start()

    def _cancel_timers(self) -> None:
        for timer in self._timers:
            timer.cancel()
        self._timers.clear()


def _wake_main_thread() -> None:
    """Deliver SIGINT to the main thread itself: a real signal also cuts short a blocking call it is in (a lock,
    a socket read, a sleep), which ``_thread.interrupt_main`` alone would not."""
    if hasattr(signal, "pthread_kill"):
        ident = threading.main_thread().ident
        if ident is not None:
            signal.pthread_kill(ident, signal.SIGINT)
            return
    _thread.interrupt_main(signal.SIGINT)  # pragma: no cover - platforms without pthread_kill
