"""Silencing C-level stdout, for pybullet's unconditional prints (they would corrupt ``--json`` output)."""

from __future__ import annotations

import io
import os
import re
import sys
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO, Any


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


_FFLUSH: list[Any] = []


def _flush_c_stdio() -> None:
    """Flush C stdio buffers so text printed while silenced is not written after the redirect ends."""
    try:
        if not _FFLUSH:
            import ctypes

            _FFLUSH.append(ctypes.CDLL(None).fflush)
        _FFLUSH[0](None)
    except (OSError, AttributeError):
        pass


def _scratch_file() -> IO[bytes]:
    """A nameless file to capture into: in memory (``memfd``) where Linux offers it, else a temporary file."""
    make = getattr(os, "memfd_create", None)
    if make is not None:
        try:
            return open(make("robokit-captured-output", os.MFD_CLOEXEC), "w+b")  # noqa: SIM115 - caller closes
        except OSError:  # an old kernel, a sandbox refusing it
            pass
    import tempfile

    return tempfile.TemporaryFile()  # noqa: SIM115 - closed by the caller


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


_ARGV = re.compile(r"^(argv\[\d+\]=\s*|pybullet build time: .*)$")


class CapturedOutput:
    """What C code wrote to file descriptor 1 while :func:`capture_c_stdout` was active (``text``, set when the
    capture ends)."""

    __slots__ = ("text",)

    def __init__(self, text: str = "") -> None:
        self.text = text

    def __repr__(self) -> str:
        return f"CapturedOutput(text={self.text!r})"

    def lines(self) -> list[str]:
        """Non-empty lines, without pybullet's empty start-up echo (``argv[0]=``)."""
        return [line.rstrip() for line in self.text.splitlines() if line.strip() and not _ARGV.match(line)]

    def messages(self) -> list[str]:
        """What pybullet said, one entry per message: a ``b3Warning[file.cpp,126]:`` header (where in Bullet's C++
        the print sits) is dropped and the text it announces kept (on the same line or the next)."""
        out: list[str] = []
        lines = self.lines()
        i = 0
        while i < len(lines):
            header = _B3_HEADER.match(lines[i])
            if header is None:
                out.append(lines[i].strip())
            elif header["text"]:
                out.append(header["text"])
            elif i + 1 < len(lines) and not _B3_HEADER.match(lines[i + 1]):
                i += 1
                out.append(lines[i].strip())
            i += 1
        return out

    def summary(self) -> str | None:
        """One line for stderr: how many messages pybullet printed and what the most frequent kind says; messages
        that differ only in their last word (a joint or link name) count as one kind, their last words listed."""
        messages = self.messages()
        if not messages:
            return None
        kinds = Counter(_stem(m) for m in messages)
        top, n = max(kinds.items(), key=lambda kind: kind[1])  # the first most frequent, as most_common(1)
        said = sorted({m for m in messages if _stem(m) == top}, key=messages.index)
        text = said[0] if len(said) == 1 else f"{top} ... ({_names([m[len(top):].strip() for m in said])})"
        text = text if len(text) <= 160 else text[:157] + "..."
        return (f"robokit: pybullet printed {len(messages)} message(s) of its own ({len(kinds)} kind(s)), most often "
                f"({n}x): {text}")


_B3_HEADER = re.compile(r"^b3(Warning|Error|Printf|Assert)\[[^\]]*\]:\s*(?P<text>.*)$")


def _stem(message: str) -> str:
    """A message without its last word (``... axis chest`` and ``... axis neck`` are one kind)."""
    return message.rsplit(" ", 1)[0] if " " in message else message


def _names(words: list[str], shown: int = 4) -> str:
    return ", ".join(words[:shown]) + (f", +{len(words) - shown} more" if len(words) > shown else "")


@contextmanager
def capture_c_stdout() -> Iterator[CapturedOutput]:
    """Send file descriptors 1 and 2 of C code (pybullet's b3Warning lines, build banner, GUI chatter) to a file.

    Python's ``sys.stdout`` and ``sys.stderr`` keep writing to the real streams: when they are descriptors 1 and 2
    they are re-opened on duplicates for the duration. The captured text is in the yielded object afterwards.
    """
    captured = CapturedOutput()
    _flush_c_stdio()
    streams = ("stdout", "stderr")
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    olds = {name: getattr(sys, name) for name in streams}
    swapped = []
    with _scratch_file() as sink:
        try:  # set up inside: an interrupt half-way still gets the real streams back
            for fd, name in zip((1, 2), streams, strict=True):
                stream = olds[name]
                try:
                    stream.flush()
                    real = stream.fileno() == fd
                except (AttributeError, OSError, ValueError):  # captured or replaced stream (pytest): fd only
                    real = False
                os.dup2(sink.fileno(), fd)
                if real:
                    setattr(sys, name, io.TextIOWrapper(os.fdopen(os.dup(saved[fd]), "wb"),
                                                        encoding=stream.encoding, errors=stream.errors,
                                                        line_buffering=True))
                    swapped.append(name)
            yield captured
        finally:
            _flush_c_stdio()
            for name in swapped:
                try:
                    getattr(sys, name).flush()
                    getattr(sys, name).close()
                except OSError:  # a closed pipe (robokit ... | head): nothing left to write to
                    pass
                setattr(sys, name, olds[name])
            for fd, old in saved.items():
                os.dup2(old, fd)
                os.close(old)
            sink.seek(0)
            captured.text = sink.read().decode("utf-8", errors="replace")
