"""Outputs that exist completely or not at all, under the name asked for.

Every file robokit makes from a record (a video, a page, an export, the pose log) is written to a temporary name in
the same folder (``.<name>.part-<pid><suffix>``: hidden, same extension, same file system), checked, and renamed
onto the name asked for. A failure or an interrupt removes the temporary file: the name asked for then holds
whatever it held before (nothing, or an older complete file), never a cut one.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Iterator
from pathlib import Path

EXIT_OUTPUT_FAILED = 6
"""Exit code when an output could not be made (the record's code: the run and its result are kept)."""


class OutputFailed(Exception):
    """An output could not be written in full; the message names the file and the reason (one line)."""

    def __init__(self, path: Path | str, reason: str) -> None:
        self.path, self.reason = Path(path), reason
        super().__init__(f"{path}: not written: {reason}")


def part_name(out: Path) -> Path:
    """The temporary name ``out`` is written under before it is renamed (same folder, same extension)."""
    return out.with_name(f".{out.name}.part-{os.getpid()}{out.suffix}")


@contextlib.contextmanager
def atomic_output(out: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``out``; rename it onto ``out`` when the block ends normally.

    Whatever ends the block otherwise (an exception, an interrupt) removes the temporary file and passes on. An
    ``OSError`` (a full disk, a file-size limit) becomes :class:`OutputFailed` naming ``out``.
    """
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = part_name(out)
    try:
        yield tmp
        os.replace(tmp, out)
    except OSError as exc:
        raise OutputFailed(out, exc.strerror or str(exc)) from exc
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)


def write_bytes(out: Path, data: bytes) -> Path:
    """Write ``data`` to ``out`` atomically (see :func:`atomic_output`)."""
    with atomic_output(out) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    return out


def write_text(out: Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``out`` atomically."""
    return write_bytes(out, text.encode("utf-8"))


def file_digest(path: Path) -> str:
    """``sha256:<hex>`` of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return "sha256:" + h.hexdigest()
