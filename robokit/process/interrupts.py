"""Ctrl-C, SIGTERM and the wall-clock budget: stop promptly, keep the result.

One :class:`StopGuard` handles SIGINT and SIGTERM for a whole command. What a signal does depends on the *phase*
the command is in (phases nest; the innermost decides):

- **no phase** or **immediate** (:meth:`StopGuard.immediate`: building the world, a delivery waiting on a slow
  server): :class:`~robokit.errors.Interrupted` is raised at once;
- **soft** (:meth:`StopGuard.soft`, the physics loop): the first signal asks the loop to stop at the next tick
  boundary;
- **deferred** (:meth:`StopGuard.deferred`: start-up, imports, the writes at the end of a run): the first signal is
  only noted, so nothing is left half-imported or half-written; the command checks :attr:`StopGuard.signalled`
  at its next boundary.

In a soft or deferred phase, if the phase has not ended ``grace`` seconds after the first signal (a plugin stuck in
a slow call), ``Interrupted`` is raised in the main thread wherever it is; a second signal raises at once. Inside
:meth:`StopGuard.critical` (writing ``result.json``) the raise waits until the section ends.

The console script installs one guard for the whole process before anything heavy is imported
(:meth:`StopGuard.for_process`), so a signal is handled from robokit's first line to its last: the exit code is
130 for SIGINT and 143 for SIGTERM (:data:`SIGNAL_EXIT_CODES`), with a one-line message. Once the command's exit
code is decided (:meth:`StopGuard.closing`), a signal ends the process at once with that code.

The wall-clock budget (``--max-wall``, ``[world] max_wall_time``) is a watchdog thread that does the same when the
budget runs out: ask the loop to stop, then break out of a call that does not return. This is the one place robokit
looks at the wall clock for anything but GUI pacing: it is a watchdog, not logic.

Signals can only be handled in the main thread; elsewhere (a worker thread) the guard is inert and the loop just
stops at tick boundaries when asked.
"""

from __future__ import annotations

import _thread
import atexit
import itertools
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any, NamedTuple

from robokit.errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)
SIGNAL_EXIT_CODES = {"SIGINT": 130, "SIGTERM": 143}
"""Exit code of a command stopped by each signal (128 + the signal's number, as shells report it)."""
GRACE = 0.5
"""Seconds a soft or deferred phase gets to reach its boundary after a signal before it is broken out of."""
STARTUP_GRACE = 0.5
"""The same for start-up (imports, plugin loading, building the world): long enough to reach the point where a
result can be written, short enough to end within a second."""


def exit_code_for(signal_name: str | None) -> int:
    """130 for SIGINT (and anything unnamed), 143 for SIGTERM."""
    return SIGNAL_EXIT_CODES.get(signal_name or "SIGINT", 130)


class _Phase(NamedTuple):
    """One phase of a command and what a signal does in it (immutable: a changed phase is a new one)."""

    ident: int
    on_signal: Callable[[str], None] | None  # None: deferred (only noted)
    grace: float
    absorbs: tuple[str, ...] = ()  # signals that only end this phase (KeyboardInterrupt), not the command
    raises: bool = False  # a signal raises at once (a wait worth breaking: building the world, a network call)


class StopGuard:
    """SIGINT/SIGTERM handling for one command. Use as a context manager (installs and restores the handlers).

    Attributes:
        signal: Name of the first signal received (``"SIGINT"``, ``"SIGTERM"``), or None.
    """

    _ids = itertools.count(1)

    def __init__(self, grace: float = GRACE) -> None:
        self.grace = grace
        self.signal: str | None = None
        self.installed = False
        self._old: dict[int, Any] = {}
        self._phases: list[_Phase] = []
        self._force: tuple[int, str] | None = None  # (phase id, reason) a timer asks to break out of
        self._critical = 0
        self._postponed: str | None = None
        self._closing: tuple[int, str] | None = None
        self._process = False
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

    @classmethod
    def for_process(cls) -> StopGuard:
        """Install a guard for the rest of the process, in a deferred phase (start-up): the console script's first
        call. Never uninstalled; :meth:`closing` decides what a signal does once the exit code is known."""
        guard = cls().__enter__()
        guard._phases.append(_Phase(next(cls._ids), None, STARTUP_GRACE))
        guard._process = True
        return guard

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

    # ----------------------------------------------------------------- state
    @property
    def signalled(self) -> bool:
        """A signal was received."""
        return self.signal is not None

    @property
    def exit_code(self) -> int:
        """The exit code the signal received asks for (130 / 143); 130 if none was."""
        return exit_code_for(self.signal)

    def _phase(self) -> _Phase | None:
        return self._phases[-1] if self._phases else None

    # ----------------------------------------------------------------- handling
    def _handle(self, signum: int, _frame: FrameType | None) -> None:
        if self._force is not None:  # our own timer asks to break out of a call that does not return
            (ident, reason), self._force = self._force, None
            phase = self._phase()
            if phase is not None and phase.ident == ident:  # still in that phase (else it ended meanwhile)
                self._raise(reason)
            return
        name = signal.Signals(signum).name
        phase = self._phase()
        if phase is not None and name in phase.absorbs:
            raise KeyboardInterrupt(name)
        if self._closing is not None:
            code, earlier = self._closing
            _exit_now(code if earlier else exit_code_for(name), name)
        first = self.signal is None
        if first:
            self.signal = name
            if self._process:  # objects a forced break leaves half-built may complain as they go: the process ends
                sys.unraisablehook = _ignore_unraisable
        if first and phase is not None and not phase.absorbs and not phase.raises:
            if phase.on_signal is not None:
                phase.on_signal(name)
            self._force_after(phase, name)
            return
        self._raise(name)

    def _raise(self, reason: str) -> None:
        if self._critical:
            self._postponed = reason
            return
        raise Interrupted(reason)

    @contextmanager
    def _entered(self, on_signal: Callable[[str], None] | None, grace: float) -> Iterator[_Phase]:
        phase = _Phase(next(self._ids), on_signal, grace)
        self._phases.append(phase)
        try:
            yield phase
        finally:
            self._phases.remove(phase)
            if self._force is not None and self._force[0] == phase.ident:
                self._force = None

    @contextmanager
    def soft(self, stop: Callable[[str], None], grace: float | None = None) -> Iterator[None]:
        """The physics loop: a signal calls ``stop(signal_name)`` instead of raising (see the module docstring)."""
        with self._entered(stop, self.grace if grace is None else grace):
            yield

    @contextmanager
    def deferred(self, grace: float | None = None) -> Iterator[None]:
        """A signal is only noted (:attr:`signalled`); after ``grace`` seconds still inside, it breaks out."""
        with self._entered(None, self.grace if grace is None else grace):
            yield

    @contextmanager
    def immediate(self) -> Iterator[None]:
        """Inside a deferred phase, a part that a signal breaks into at once (building the world: nothing built
        is kept; a network call: the reporter keeps the result in its outbox)."""
        phase = _Phase(next(self._ids), None, self.grace, raises=True)
        self._phases.append(phase)
        try:
            yield
        finally:
            self._phases.remove(phase)

    @contextmanager
    def absorbing(self, signals: tuple[str, ...] = ("SIGINT",)) -> Iterator[None]:
        """A wait the user ends with a signal (``--gui-hold``'s window): ``signals`` raise a plain
        ``KeyboardInterrupt`` and are not the command's signal (its exit code stays); others raise at once."""
        phase = _Phase(next(self._ids), None, self.grace, tuple(signals))
        self._phases.append(phase)
        try:
            yield
        finally:
            self._phases.remove(phase)

    @contextmanager
    def critical(self) -> Iterator[None]:
        """A short section that must not be broken into (an atomic write): a raise waits until it ends."""
        self._critical += 1
        try:
            yield
        finally:
            self._critical -= 1
            if not self._critical and self._postponed is not None:
                reason, self._postponed = self._postponed, None
                raise Interrupted(reason)

    def acted_on(self) -> None:
        """The signal received has been acted on (the run ends ``aborted`` before it began): the forced break its
        phase's grace would still bring is dropped, so it cannot break into the keeping of the result later."""
        self._cancel_timers()

    def closing(self, code: int) -> int:
        """The command is done with exit code ``code``: returns the code to exit with (the signal's if one was
        received) and from now on a signal ends the process at once (output flushed) with that code."""
        final = self.exit_code if self.signalled else code
        self._closing = (final, self.signal or "")
        self._cancel_timers()
        if self.installed and hasattr(signal, "pthread_sigmask"):
            # Past this point Python's own shutdown puts the default handlers back (a SIGTERM would kill the process
            # with no word): hold the signals back instead, and look for one as the last exit handler runs.
            signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
            atexit.register(_exit_if_pending, final, bool(self.signal))
        return final

    def _force_after(self, phase: _Phase, reason: str) -> None:
        """Raise ``Interrupted(reason)`` in the main thread after the phase's grace unless it ended by then."""
        if not self.installed:
            return

        def fire() -> None:
            if phase not in self._phases:
                return
            self._force = (phase.ident, reason)
            _wake_main_thread()  # runs _handle in the main thread, which re-checks

        self._start_timer(phase.grace, fire)

    def force_after(self, seconds: float, reason: str) -> None:
        """Raise ``Interrupted(reason)`` in the main thread after ``seconds`` unless the current phase ended."""
        phase = self._phase()
        if phase is not None:
            self._force_after(_Phase(phase.ident, phase.on_signal, seconds), reason)

    def watchdog(self, seconds: float, on_expire: Callable[[], None], reason: str) -> None:
        """After ``seconds``: call ``on_expire()`` (from the watchdog thread: it should only set a flag), then
        break out with ``Interrupted(reason)`` if the current phase has not ended ``grace`` seconds later."""
        phase = self._phase()

        def fire() -> None:
            if phase is None or phase not in self._phases:
                return
            on_expire()
            self._force_after(phase, reason)

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


def _exit_if_pending(code: int, earlier: bool) -> None:
    """At exit: a SIGINT / SIGTERM held back since the command ended ends the process with its code (the command's
    own code if a signal had already decided it)."""
    pending = signal.sigpending() & set(SIGNALS)
    if pending:
        sig = signal.Signals(min(pending))
        _exit_now(code if earlier else exit_code_for(sig.name), sig.name)


def _ignore_unraisable(_unraisable: Any) -> None:
    """After a signal, a finaliser of something the break left half-built (a half-made pybullet client) may raise:
    not worth a traceback on the way out."""


def _exit_now(code: int, name: str) -> None:
    """End the process at once: the command's work is done (its exit code decided), a signal only hurries it."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    try:
        os.write(2, f"robokit: interrupted ({name}) while exiting; exit code {code}\n".encode())
    except OSError:
        pass
    os._exit(code)


def _wake_main_thread() -> None:
    """Deliver SIGINT to the main thread itself: a real signal also cuts short a blocking call it is in (a lock,
    a socket read, a sleep), which ``_thread.interrupt_main`` alone would not."""
    if hasattr(signal, "pthread_kill"):
        ident = threading.main_thread().ident
        if ident is not None:
            signal.pthread_kill(ident, signal.SIGINT)
            return
    _thread.interrupt_main(signal.SIGINT)  # pragma: no cover - platforms without pthread_kill
