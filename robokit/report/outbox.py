"""The outbox: results not delivered yet, kept as files until a flush delivers them.

Layout of an outbox folder::

    <dir>/<run_id>.json          a waiting entry (payload + url + delivery options + attempts + last error)
    <dir>/failed/<run_id>.json   refused by the server (a 4xx other than 408/429), with the server's answer
    <dir>/.locks/<run_id>.lock   per-entry file lock (``filelock``), held while the entry is being sent

Delivery is write-ahead: the sender takes the entry's lock, writes the entry, sends it, and deletes it only after a
2xx. A crash anywhere between leaves the entry in place, so a later flush sends it again with the same
``Idempotency-Key`` (the run id); a server that honours the key stores it once. Two flushes at once never send the
same entry twice: each takes the entry's lock without waiting (a busy entry is skipped) and re-reads the entry
under the lock (it may have been delivered meanwhile).

Entries never hold secrets: the bearer token is read from the environment at send time (see
:mod:`robokit_plugins.http_report`).
"""

from __future__ import annotations

import datetime as dt
import json
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from filelock import FileLock, Timeout

from robokit.report.reporting import write_json_atomic

SCHEMA = "robokit.report.outbox/1"
IN_FLIGHT = "no answer recorded: the sender stopped while sending (it is sent again on the next flush)"
"""``last_error`` of an entry while it is being sent; it stays if the sender is killed mid-send."""
_SAFE_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")


@dataclass(frozen=True)
class SendResult:
    """One delivery attempt's answer.

    Attributes:
        ok: The server answered 2xx.
        permanent: Retrying cannot help (a 4xx other than 408/429, or a payload over the size limit).
        status: HTTP status of the last answer, or None when there was none (connection error, timeout).
        detail: One line for people: the error, or the status and the start of the server's answer.
        body: The server's answer (truncated), kept with a failed entry.
    """

    ok: bool
    permanent: bool = False
    status: int | None = None
    detail: str = ""
    body: str = ""


class OutboxError(OSError):
    """The outbox's own files could not be written or removed (a filesystem problem, not a network one)."""


def _write(path: Path, data: dict[str, Any]) -> None:
    try:
        write_json_atomic(path, data, overwrite=True)
    except OSError as exc:
        raise OutboxError(f"outbox {path}: cannot write: {exc.strerror or exc}") from None


Sender = Callable[["Entry"], SendResult]
"""Sends one entry (``entry.url``, ``entry.payload``, ``entry.options``) and says what happened."""


@dataclass
class Entry:
    """One outbox file and its content (``run_id``, ``url``, ``payload``, ``options``, ``attempts``...)."""

    path: Path
    data: dict[str, Any]

    @property
    def run_id(self) -> str:
        return str(self.data["run_id"])

    @property
    def url(self) -> str:
        return str(self.data["url"])

    @property
    def payload(self) -> dict[str, Any]:
        return dict(self.data["payload"])

    @property
    def options(self) -> dict[str, Any]:
        return dict(self.data.get("options") or {})

    @property
    def attempts(self) -> int:
        return int(self.data.get("attempts", 0))

    @property
    def last_error(self) -> str | None:
        return self.data.get("last_error")

    @property
    def age(self) -> float:
        """Seconds since the entry was created (wall clock: this is bookkeeping, not simulation)."""
        return max(0.0, time.time() - float(self.data.get("created_at", time.time())))


@dataclass
class FlushReport:
    """What a flush did, by run id, in the order entries were taken (oldest first)."""

    delivered: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    waiting: list[str] = field(default_factory=list)
    busy: list[str] = field(default_factory=list)
    not_tried: list[str] = field(default_factory=list)
    lines: list[str] = field(default_factory=list)

    @property
    def clean(self) -> bool:
        """Every entry taken was delivered (nothing failed, nothing left waiting)."""
        return not (self.failed or self.waiting or self.busy or self.not_tried)

    def counts(self) -> str:
        return (f"{len(self.delivered)} delivered, {len(self.failed)} refused (moved to failed/), "
                f"{len(self.waiting) + len(self.not_tried)} still waiting, {len(self.busy)} busy in another flush")


def _now_iso() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


class Outbox:
    """An outbox folder (created on first write). See the module docstring for the layout and the protocol."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.failed_dir = self.root / "failed"
        self.locks_dir = self.root / ".locks"

    def path_for(self, run_id: str) -> Path:
        """The entry file of a run id (which must be a plain file name: letters, digits, ``.``, ``_``, ``-``)."""
        if not _SAFE_ID.match(run_id):
            raise ValueError(f"run id {run_id!r} cannot name an outbox file")
        return self.root / f"{run_id}.json"

    def lock(self, run_id: str, timeout: float = 30.0) -> FileLock:
        """The file lock of one entry (not yet acquired). ``timeout`` in seconds; 0 = fail at once if busy."""
        self.path_for(run_id)
        self.locks_dir.mkdir(parents=True, exist_ok=True)
        return FileLock(str(self.locks_dir / f"{run_id}.lock"), timeout=timeout)

    def drop_lock_file(self, run_id: str) -> None:
        """Delete a settled entry's lock file (call with the lock held, after the entry was delivered or moved).

        Safe because every sender re-reads the entry under the lock: whoever locks the old or a new lock file
        afterwards finds no entry and sends nothing. (A waiting entry keeps its lock file: two senders holding
        different lock files for it could both send it.)
        """
        if not self.path_for(run_id).exists():
            (self.locks_dir / f"{run_id}.lock").unlink(missing_ok=True)

    def put(self, payload: dict[str, Any], url: str, options: dict[str, Any] | None = None, *,
            last_error: str | None = None) -> Entry:
        """Write a new entry atomically (call with the entry's lock held). Returns it."""
        run_id = str(payload["run_id"])
        now = time.time()
        data = {"schema": SCHEMA, "run_id": run_id, "url": url, "created_at": now, "created": _now_iso(),
                "attempts": 0, "last_error": last_error, "last_attempt": None, "options": dict(options or {}),
                "payload": payload}
        entry = Entry(self.path_for(run_id), data)
        _write(entry.path, data)
        return entry

    def load(self, run_id: str) -> Entry | None:
        """The waiting entry of ``run_id``, or None if there is none."""
        path = self.path_for(run_id)
        try:
            return Entry(path, json.loads(path.read_text(encoding="utf-8")))
        except FileNotFoundError:
            return None

    def entries(self) -> list[Entry]:
        """Waiting entries, oldest first. Unreadable files are skipped (see :meth:`unreadable`)."""
        return self._read_all(self.root)

    def failed(self) -> list[Entry]:
        """Entries the server refused, oldest first."""
        return self._read_all(self.failed_dir)

    def unreadable(self) -> list[tuple[Path, str]]:
        """Entry files that cannot be used, with why: not readable (a filesystem error, said as such), not a JSON
        entry (never produced by robokit's atomic writes), or a run id that cannot name an outbox file."""
        found = []
        for path in sorted(self.root.glob("*.json")):
            why = self._problem(path)
            if why is not None:
                found.append((path, why))
        return found

    @classmethod
    def _problem(cls, path: Path) -> str | None:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except OSError as exc:
            return f"cannot be read: {exc.strerror or exc}"
        except ValueError:
            return "not a robokit outbox entry (not JSON)"
        if not isinstance(data, dict) or not {"run_id", "url", "payload"} <= data.keys():
            return "not a robokit outbox entry (no run_id, url and payload)"
        if not _SAFE_ID.match(str(data["run_id"])):
            return f"run id {str(data['run_id'])[:40]!r} cannot name an outbox file: skipped"
        return None

    @classmethod
    def _read_all(cls, folder: Path) -> list[Entry]:
        found = [e for e in (cls._read(p) for p in folder.glob("*.json")) if e is not None]
        return sorted(found, key=lambda e: (float(e.data.get("created_at", 0.0)), e.run_id))

    @staticmethod
    def _read(path: Path) -> Entry | None:
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(data, dict) or not {"run_id", "url", "payload"} <= data.keys():
            return None
        if not _SAFE_ID.match(str(data["run_id"])):
            return None
        return Entry(path, data)

    def attempt(self, entry: Entry, send: Sender) -> tuple[str, Entry, SendResult]:
        """Send one entry and settle it (call with its lock held).

        Records the attempt first (so a crash mid-send leaves ``attempts`` and :data:`IN_FLIGHT`), sends, then:
        2xx → the entry is deleted; permanent refusal → moved to ``failed/`` with the answer; anything else →
        kept, with the error recorded.

        Returns:
            (``"delivered"`` | ``"failed"`` | ``"waiting"``, the entry as it now is, the send result).
        """
        data = {**entry.data, "attempts": entry.attempts + 1, "last_error": IN_FLIGHT, "last_attempt": _now_iso()}
        entry = Entry(entry.path, data)
        _write(entry.path, data)
        try:
            result = send(entry)
        except KeyboardInterrupt:  # Ctrl-C mid-send: say so in the entry (it is sent again by the next flush)
            stopped = {**data, "last_error": "interrupted (Ctrl-C / SIGTERM) while sending; no answer recorded"}
            _write(entry.path, stopped)
            raise
        if result.ok:
            try:
                entry.path.unlink(missing_ok=True)
            except OSError as exc:  # delivered, but it would be sent again (the server dedups by run id)
                raise OutboxError(f"outbox {entry.path}: delivered, but the entry cannot be removed: "
                                  f"{exc.strerror or exc}") from None
            return "delivered", entry, result
        if result.permanent:
            return "failed", self._move_to_failed(entry, result), result
        data = {**data, "last_error": result.detail or "not delivered"}
        _write(entry.path, data)
        return "waiting", Entry(entry.path, data), result

    def _move_to_failed(self, entry: Entry, result: SendResult) -> Entry:
        data = {**entry.data, "last_error": result.detail,
                "server_answer": {"status": result.status, "body": result.body, "at": _now_iso()}}
        failed = Entry(self.failed_dir / entry.path.name, data)
        _write(failed.path, data)
        try:
            entry.path.unlink(missing_ok=True)
        except OSError as exc:
            raise OutboxError(f"outbox {entry.path}: cannot remove the entry: {exc.strerror or exc}") from None
        return failed

    def flush(self, send: Sender, *, stop_on_transient: bool = True, url: str | None = None) -> FlushReport:
        """Deliver waiting entries, oldest first, one at a time under each entry's lock.

        An entry that can never be delivered (refused with a 4xx, a malformed URL) moves to ``failed/`` and the
        flush goes on; entries whose file cannot be used (unreadable, not an entry, a bad run id) are skipped with
        a warning line.

        Args:
            send: Delivers one entry (see :data:`Sender`); its ``target`` attribute, if any, maps an entry to where
                it is really sent (a flush with ``--url`` sends every entry to one place).
            stop_on_transient: After an entry could not be delivered for a reason that may pass (server down,
                5xx, timeout), leave the later entries *for the same destination* for the next flush, in order;
                entries for other servers are still tried.
            url: Only entries made for this URL (None: all).
        """
        target = getattr(send, "target", None) or (lambda e: e.url)
        report = FlushReport()
        for path, why in self.unreadable():
            report.lines.append(f"warning: {path}: {why}")
        pending = [e for e in self.entries() if url is None or e.url == url]
        down: set[str] = set()  # destinations that just failed for a passing reason (server down, 5xx)
        for snapshot in pending:
            if stop_on_transient and target(snapshot) in down:
                report.not_tried.append(snapshot.run_id)  # same server: try again later, in order
                continue
            lock = self.lock(snapshot.run_id, timeout=0)
            try:
                lock.acquire()
            except Timeout:
                report.busy.append(snapshot.run_id)
                continue
            try:
                entry = self.load(snapshot.run_id)  # re-read under the lock: another flush may have sent it
                if entry is None:
                    continue
                outcome, entry, result = self.attempt(entry, send)
                self.drop_lock_file(snapshot.run_id)
            finally:
                lock.release()
            getattr(report, outcome).append(entry.run_id)
            report.lines.append(_line(outcome, entry, result))
            if outcome == "waiting":
                down.add(target(snapshot))
        return report


def _line(outcome: str, entry: Entry, result: SendResult) -> str:
    if outcome == "delivered":
        return f"{entry.run_id}: delivered to {entry.url} (HTTP {result.status})"
    if outcome == "failed":
        return f"{entry.run_id}: refused ({result.detail}); moved to {entry.path}"
    return f"{entry.run_id}: still waiting ({result.detail})"
