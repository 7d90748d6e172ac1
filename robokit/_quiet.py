"""Silencing C-level stdout, for pybullet's unconditional prints (they would corrupt ``--json`` output)."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def quiet_stdout() -> Iterator[None]:
    """Send file descriptors 1 and 2 to /dev/null for the duration (Python's streams are flushed first).

    Only wrap calls that report failure by raising: anything they print is lost.
    """
    fds = []
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
            fds.append(stream.fileno())
        except (AttributeError, OSError, ValueError):  # captured or replaced stream: no fd to guard
            continue
    saved = [os.dup(fd) for fd in fds]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in fds:
            os.dup2(devnull, fd)
        yield
    finally:
        _flush_c_stdio()
        for fd, old in zip(fds, saved, strict=True):
            os.dup2(old, fd)
            os.close(old)
        os.close(devnull)


def _flush_c_stdio() -> None:
    """Flush C stdio buffers so text printed while silenced is not written after the redirect ends."""
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass


@contextmanager
def c_stdout_to_stderr() -> Iterator[None]:
    """Point file descriptor 1 at stderr for the duration, so C libraries' prints cannot corrupt stdout.

    Python's own ``sys.stdout`` is flushed before and after; use this around a run whose stdout must stay clean
    (``robokit run --json``).
    """
    try:
        sys.stdout.flush()
        out_fd, err_fd = sys.stdout.fileno(), sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        yield
        return
    saved = os.dup(out_fd)
    try:
        os.dup2(err_fd, out_fd)
        yield
    finally:
        _flush_c_stdio()
        sys.stdout.flush()
        os.dup2(saved, out_fd)
        os.close(saved)
