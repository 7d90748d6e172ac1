"""The ``robokit`` console script's entry point: SIGINT and SIGTERM are handled from its first instruction.

This module imports nothing but :mod:`signal` and :mod:`sys` before it installs its handlers, so a signal that
arrives while the command line interface is still being imported (tens of milliseconds; more on a loaded machine)
is noted instead of printing a traceback (SIGINT) or killing the process with no word (SIGTERM). Once
:func:`robokit.cli.main` has installed robokit's own guard, a noted signal is delivered again and handled as any
signal during start-up: one line, exit 130 / 143, and ``robokit run`` keeps an ``aborted`` result.

What no Python code can guard is the interpreter's own start-up before this module runs (loading Python and the
environment's ``site`` files).
"""

import signal
import sys

_noted: list[int] = []


def _note(signum: int, _frame: object) -> None:
    """A signal before robokit's guard exists: remember it (the first two: a second one hurries, as later)."""
    if len(_noted) < 2:
        _noted.append(signum)


for _signum in (signal.SIGINT, signal.SIGTERM):
    signal.signal(_signum, _note)


def noted() -> list[int]:
    """The signals received before robokit's guard was installed, and forget them (the guard re-delivers them)."""
    out = list(_noted)
    _noted.clear()
    return out


def main() -> int:
    """Run ``robokit`` with the process's command line; returns the exit code."""
    from robokit.cli import main as cli_main

    return cli_main()


if __name__ == "__main__":
    sys.exit(main())
