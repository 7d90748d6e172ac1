"""Turning a RunResult into the payload reporters deliver, and running the reporters.

The payload is the RunResult dict with the course server's fields (``student``, ``project``, ``red_sorted``,
``blue_sorted``, ``failures``, ``total_time``) copied to the top level when present, for compatibility with
lesson 08's ``POST /api/robotics/result/``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robokit.components import Delivery
from robokit.core.result import RunResult
from robokit.errors import Interrupted, plugin_fault

COURSE_FIELDS = ("red_sorted", "blue_sorted", "failures", "total_time")
EXIT_REFUSED = 5
"""Exit code of ``robokit run`` when the server refused the result (a 4xx, or no token where one was named): the
result is kept (``results/<run_id>/``, ``outbox/failed/``) and ``robokit outbox retry`` sends it once fixed."""


@dataclass(frozen=True)
class Refused(Delivery):
    """A delivery the server refused for good (or that could not be sent as configured, e.g. its token variable
    is unset). ``why`` is the server's answer in one line, ``advice`` what to change."""

    why: str = ""
    advice: str = ""
    status: int | None = None

    def line(self) -> str:
        """One line for people: the HTTP status and what to change (else the server's answer)."""
        where = f" (HTTP {self.status})" if self.status else ""
        return f"refused{where}: {self.advice or self.why}" + (f"; the result is kept ({self.stored})"
                                                               if self.stored else "")


def build_payload(
    result: RunResult, *, student: str | None = None, project: str | None = None
) -> dict[str, Any]:
    """The RunResult as a dict plus the course's top-level fields. The config is named as the run's folder sees
    it (relative to the working folder, or its file name alone): a payload carries no path of the machine that
    made it."""
    payload = result.to_dict()
    if isinstance(payload.get("config"), str):
        payload["config"] = portable_path(payload["config"])
    if isinstance(payload.get("reason"), str):
        payload["reason"] = portable_text(payload["reason"])
    if isinstance(payload.get("warnings"), list):
        payload["warnings"] = [portable_text(w) if isinstance(w, str) else w for w in payload["warnings"]]
    if student is not None:
        payload["student"] = student
    if project is not None:
        payload["project"] = project
    for key in COURSE_FIELDS:
        if key in payload["result"]:
            payload[key] = payload["result"][key]
    return payload


def portable_path(path: str) -> str:
    """``path`` relative to the working folder (forward slashes) when it lies inside it, else its file name."""
    p = Path(path)
    if not p.is_absolute():
        return p.as_posix()
    try:
        return p.relative_to(Path.cwd()).as_posix()
    except (ValueError, OSError):
        return p.name


def portable_text(text: str) -> str:
    """``text`` (a reason, a warning) with this machine's folders written portably: the working folder's prefix
    dropped (paths become relative), Python's environment as ``<python>``, the home folder as ``~``."""
    import sys

    places = [(str(Path.cwd()) + os.sep, ""), (sys.prefix + os.sep, "<python>" + os.sep),
              (str(Path.home()) + os.sep, "~" + os.sep)]
    for prefix, short in sorted(places, key=lambda p: -len(p[0])):
        if len(prefix) > 1:
            text = text.replace(prefix, short)
    return text


def deliver(reporters: Iterable[Any], payload: dict[str, Any], *, stop: Any = None) -> list[tuple[str, Delivery]]:
    """Run every reporter; a reporter that raises counts as a failed, unstored delivery (never propagates).

    Once ``stop`` (a :class:`robokit.process.interrupts.StopGuard`) has seen Ctrl-C / SIGTERM, reporters are asked to
    ``keep()`` the payload instead (store it without sending: an HTTP reporter queues it in its outbox), so
    stopping never waits on a network; local reporters are run first.
    """
    out = []
    for reporter in sorted(reporters, key=lambda r: getattr(r, "sends", False)):
        try:
            if stop is not None and stop.signalled and hasattr(reporter, "keep"):
                delivery = reporter.keep(payload)
            else:
                delivery = reporter.report(payload)
        except Interrupted as exc:
            delivery = Delivery(False, None, f"{reporter.name}: interrupted ({exc.reason}) before the result was kept")
        except BaseException as exc:  # noqa: BLE001 - reporting never changes the run's outcome
            if isinstance(exc, KeyboardInterrupt) and not getattr(stop, "installed", False):
                raise  # no guard: this is the user's Ctrl-C, not a plugin fault
            delivery = Delivery(False, None, f"{reporter.name}: {plugin_fault(exc)}")
        out.append((reporter.name, delivery))
    return out


def write_json_atomic(path: Path, data: Any, *, overwrite: bool = False) -> None:
    """Write JSON to ``path`` through a temporary file in the same folder, fsync, and an atomic rename.

    A reader (or a crash) sees either the old file or the complete new one, never a partial write.

    Args:
        path: Destination file; its folder is created if missing.
        data: Anything ``json.dumps`` accepts.
        overwrite: Replace an existing file (outbox entries are rewritten; results never are).

    Raises:
        FileExistsError: ``path`` exists and ``overwrite`` is false.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    if not overwrite and path.exists():
        raise FileExistsError(f"{path} already exists")
    fd, tmp = _new_file_beside(path)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        if overwrite:
            os.replace(tmp, path)
        else:
            _link_no_overwrite(Path(tmp), path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _new_file_beside(path: Path) -> tuple[int, str]:
    """Create and open a new file ``.NAME.<random>.tmp`` in ``path``'s folder, readable by its owner only, never
    one that exists: what ``tempfile.mkstemp`` does, without its import (a run writes one result this way)."""
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        name = os.path.join(path.parent, f".{path.name}.{os.urandom(6).hex()}.tmp")
        try:
            return os.open(name, flags, 0o600), name
        except FileExistsError:
            continue
    raise FileExistsError(f"no free temporary file name next to {path}")


def _link_no_overwrite(tmp: Path, path: Path) -> None:
    """Move ``tmp`` to ``path`` unless ``path`` exists (a hard link is atomic and refuses to overwrite)."""
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise FileExistsError(f"{path} already exists") from None
    except OSError:  # a filesystem without hard links: check, then rename
        if path.exists():
            raise FileExistsError(f"{path} already exists") from None
        os.replace(tmp, path)
        return
    tmp.unlink()
