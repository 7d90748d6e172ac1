"""When something goes wrong: one line for people, the full traceback in a file (and on stderr with ``--debug``).

A user error (:class:`robokit.errors.UserError`) is one line and exit 2. Anything else is a bug, in robokit or in a
plugin: the user sees one line naming what raised and where (``file:line``) plus the path of a file holding the
full traceback; ``--debug`` (or ``ROBOKIT_DEBUG=1``) prints the traceback itself as well.

The traceback file goes into the run's folder (``<results dir>/<run_id>/traceback.txt``) when a run exists, else
into the system's temporary folder.
"""

from __future__ import annotations

import os
from pathlib import Path
from types import TracebackType

DEBUG_ENV = "ROBOKIT_DEBUG"


def _stdlib() -> tuple[str, ...]:
    """The standard library's folders (sysconfig and traceback are imported when something went wrong, not at
    start-up)."""
    import sysconfig

    paths = sysconfig.get_paths()
    return tuple(p for p in {paths.get("stdlib"), paths.get("platstdlib")} if p)


def debug_from_env() -> bool:
    """True when ``ROBOKIT_DEBUG`` is set to something other than empty, ``0``, ``false`` or ``no``."""
    return os.environ.get(DEBUG_ENV, "").strip().lower() not in ("", "0", "false", "no", "off")


def one_line(text: object, limit: int = 300) -> str:
    """``text`` on one line (whitespace collapsed), cut at ``limit`` characters."""
    flat = " ".join(str(text).split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def describe(exc: BaseException) -> str:
    """``"TypeError: message"`` on one line (just the type when the message is empty)."""
    msg = one_line(exc)
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def where_raised(exc: BaseException) -> str:
    """``path:line`` of the innermost frame of ``exc``'s traceback outside the standard library ("" if none).

    Paths under the working directory are shown relative to it.
    """
    import traceback

    stdlib = _stdlib()
    frames = traceback.extract_tb(_tb(exc))
    chosen = next((f for f in reversed(frames) if not f.filename.startswith(stdlib)), frames[-1] if frames else None)
    if chosen is None:
        return ""
    return f"{_short(chosen.filename)}:{chosen.lineno}"


def _tb(exc: BaseException) -> TracebackType | None:
    return exc.__traceback__


def _short(filename: str) -> str:
    try:
        return str(Path(filename).resolve().relative_to(Path.cwd()))
    except (ValueError, OSError):
        return filename


def traceback_text(exc: BaseException) -> str:
    """The full traceback of ``exc``, with its causes, as Python prints it."""
    import traceback

    return "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))


def write_traceback(text: str, run_dir: str | Path | None = None) -> Path | None:
    """Write a traceback to ``run_dir/traceback.txt`` (the folder is created) or, without a run folder or when it
    cannot be written, to a new ``robokit-traceback-*.txt`` in the system's temporary folder.

    Returns:
        The file written, or None if nothing could be written anywhere.
    """
    if run_dir is not None:
        try:
            folder = Path(run_dir)
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / "traceback.txt"
            path.write_text(text, encoding="utf-8")
            return path
        except OSError:
            pass
    import tempfile

    try:
        fd, name = tempfile.mkstemp(prefix="robokit-traceback-", suffix=".txt")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        return Path(name)
    except OSError:
        return None
