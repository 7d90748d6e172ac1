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
:mod:`robokit_plugins.http_report`). An entry belongs to whoever made it: it records the *identity* it was made
under, a fingerprint of the token (:func:`fingerprint`: the first 12 hex digits of its SHA-256, never the token) or
``"no token"``. A flush sends an entry only under that same identity; the others wait for their owner.
"""

from __future__ import annotations

import datetime as dt
import hashlib
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
NO_TOKEN = "no token"
"""The identity of an entry made (or a flush run) without a bearer token."""
UNKNOWN = "unknown (made before robokit recorded who made an entry)"


def fingerprint(token: str | None) -> str:
    """Who sends: ``"sha256:"`` + the first 12 hex digits of the token's SHA-256, or :data:`NO_TOKEN`.

    A token is 256 random bits, so 48 bits of its hash tell two students apart and reveal nothing usable."""
    if not token:
        return NO_TOKEN
    return "sha256:" + hashlib.sha256(token.encode("utf-8")).hexdigest()[:12]


@dataclass(frozen=True)
class SendResult:
    """One delivery attempt's answer.

    Attributes:
        ok: The server answered 2xx.
        permanent: Retrying cannot help (a 4xx other than 408/429, or a payload over the size limit).
        status: HTTP status of the last answer, or None when there was none (connection error, timeout).
        detail: One line for people: the error, or the status and the start of the server's answer.
        body: The server's answer (truncated), kept with a failed entry.
        note: What was done after a 2xx (e.g. ``artifacts: 3/3 uploaded ...``), or "".
        advice: For a refusal: one line saying what to change, or "".
    """

    ok: bool
    permanent: bool = False
    status: int | None = None
    detail: str = ""
    body: str = ""
    note: str = ""
    advice: str = ""


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
    def identity(self) -> str:
        """Whose entry this is: a token :func:`fingerprint` or :data:`NO_TOKEN` (see the module docstring).

        An entry written before robokit recorded identities is :data:`NO_TOKEN` if it was to be sent without a
        token, else :data:`UNKNOWN` (no flush sends it; ``robokit outbox retry RUN --claim`` does)."""
        found = self.data.get("identity")
        if isinstance(found, str):
            return found
        return UNKNOWN if self.options.get("token_env") else NO_TOKEN

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
    others: dict[str, list[str]] = field(default_factory=dict)
    """Entries left waiting because another identity made them: identity -> run ids."""
    lines: list[str] = field(default_factory=list)

    @property
    def clean(self) -> bool:
        """Every entry taken was delivered (nothing failed, nothing left waiting). An entry another sender was
        sending (``busy``) was not taken: that sender says how it went."""
        return not (self.failed or self.waiting or self.not_tried)

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

    def sweep_locks(self) -> list[str]:
        """Delete the lock files a sender left behind when it was killed after its entry was settled (delivered or
        moved to ``failed/``) but before it deleted the lock: each is taken without waiting, and deleted only if no
        entry waits under that run id (as :meth:`drop_lock_file` does). Returns the run ids whose lock went."""
        swept: list[str] = []
        try:
            locks = sorted(self.locks_dir.glob("*.lock"))
        except OSError:
            return swept
        for path in locks:
            run_id = path.stem
            try:
                if self.path_for(run_id).exists():
                    continue  # a waiting entry keeps its lock file
            except ValueError:
                continue  # not a lock robokit made
            lock = FileLock(str(path), timeout=0)
            try:
                lock.acquire()
            except (Timeout, OSError):
                continue  # a live sender holds it
            try:
                if not self.path_for(run_id).exists():
                    path.unlink(missing_ok=True)
                    swept.append(run_id)
            except OSError:
                pass
            finally:
                lock.release()
        return swept

    def put(self, payload: dict[str, Any], url: str, options: dict[str, Any] | None = None, *,
            last_error: str | None = None, identity: str = NO_TOKEN) -> Entry:
        """Write a new entry atomically (call with the entry's lock held). Returns it.

        ``identity``: whose it is, :func:`fingerprint` of the token it is to be sent with (never the token)."""
        run_id = str(payload["run_id"])
        now = time.time()
        data = {"schema": SCHEMA, "run_id": run_id, "url": url, "created_at": now, "created": _now_iso(),
                "identity": identity, "attempts": 0, "last_error": last_error, "last_attempt": None,
                "options": dict(options or {}), "payload": payload}
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
        data = {**entry.data, "last_error": result.detail, "advice": result.advice or None,
                "server_answer": {"status": result.status, "body": result.body, "at": _now_iso()}}
        failed = Entry(self.failed_dir / entry.path.name, data)
        _write(failed.path, data)
        try:
            entry.path.unlink(missing_ok=True)
        except OSError as exc:
            raise OutboxError(f"outbox {entry.path}: cannot remove the entry: {exc.strerror or exc}") from None
        return failed

    def flush(self, send: Sender, *, stop_on_transient: bool = True, url: str | None = None,
              only: set[str] | None = None) -> FlushReport:
        """Deliver waiting entries, oldest first, one at a time under each entry's lock.

        An entry that can never be delivered (refused with a 4xx, a malformed URL) moves to ``failed/`` and the
        flush goes on; entries whose file cannot be used (unreadable, not an entry, a bad run id) are skipped with
        a warning line. When ``send`` has an ``identity(entry)`` method (who would send the entry now: a token
        :func:`fingerprint` or :data:`NO_TOKEN`), an entry made under another identity is not sent: it waits for
        its owner (:attr:`FlushReport.others`) and one line says whose entries were left and how to send them.

        Args:
            send: Delivers one entry (see :data:`Sender`); its ``target`` attribute, if any, maps an entry to where
                it is really sent (a flush with ``--url`` sends every entry to one place).
            stop_on_transient: After an entry could not be delivered for a reason that may pass (server down,
                5xx, timeout), leave the later entries *for the same destination* for the next flush, in order;
                entries for other servers are still tried.
            url: Only entries made for this URL (None: all).
            only: Only these run ids (None: all).
        """
        target = getattr(send, "target", None) or (lambda e: e.url)
        who = getattr(send, "identity", None)
        report = FlushReport()
        self.sweep_locks()
        for path, why in self.unreadable():
            report.lines.append(f"warning: {path}: {why}")
        pending = [e for e in self.entries()
                   if (url is None or e.url == url) and (only is None or e.run_id in only)]
        down: set[str] = set()  # destinations that just failed for a passing reason (server down, 5xx)
        for snapshot in pending:
            if who is not None and who(snapshot) != snapshot.identity:
                report.others.setdefault(snapshot.identity, []).append(snapshot.run_id)
                continue
            if stop_on_transient and target(snapshot) in down:
                report.not_tried.append(snapshot.run_id)  # same server: try again later, in order
                continue
            settled = self._take(snapshot.run_id, send, report)
            if settled == "waiting":
                down.add(target(snapshot))
        if report.others:
            report.lines.append(others_line(report.others))
        return report

    def _take(self, run_id: str, send: Sender, report: FlushReport) -> str | None:
        """Lock, re-read and send one entry; record what happened in ``report``. Returns the outcome (or None)."""
        lock = self.lock(run_id, timeout=0)
        try:
            lock.acquire()
        except Timeout:
            report.busy.append(run_id)
            return None
        try:
            entry = self.load(run_id)  # re-read under the lock: another flush may have sent it
            if entry is None:
                return None
            outcome, entry, result = self.attempt(entry, send)
            self.drop_lock_file(run_id)
        finally:
            lock.release()
        getattr(report, outcome).append(entry.run_id)
        report.lines.append(_line(outcome, entry, result))
        return outcome

    def restore(self, entry: Entry, identity: str, payload: dict[str, Any] | None = None) -> Entry:
        """Put a refused entry (from ``failed/``) back into the outbox, bound to ``identity`` (call with its lock
        held); ``payload`` replaces the one it had (e.g. with a corrected project). Returns the waiting entry."""
        data = {k: v for k, v in entry.data.items() if k not in ("server_answer", "advice")}
        data.update(identity=identity, last_error=f"put back by robokit outbox retry (was: {entry.last_error})")
        if payload is not None:
            data["payload"] = payload
        waiting = Entry(self.path_for(entry.run_id), data)
        _write(waiting.path, data)
        if entry.path != waiting.path:
            try:
                entry.path.unlink(missing_ok=True)
            except OSError as exc:
                raise OutboxError(f"outbox {entry.path}: cannot remove the entry: {exc.strerror or exc}") from None
        return waiting


def others_line(others: dict[str, list[str]]) -> str:
    """One line: whose entries a flush left waiting, and how they are sent."""
    parts = [f"{len(ids)} made {'without a token' if who == NO_TOKEN else 'under token ' + who}"
             for who, ids in sorted(others.items())]
    line = (f"left waiting, not yours: {'; '.join(parts)}. Whoever made them sends them with "
            "`robokit outbox flush` with their own token set (`robokit outbox list` shows whose each is); "
            "`robokit outbox retry RUN` sends one made without a token as yours")
    if UNKNOWN in others:
        line += "; `robokit outbox retry RUN --claim` one made before robokit recorded whose entries are"
    return line


def _line(outcome: str, entry: Entry, result: SendResult) -> str:
    if outcome == "delivered":
        return f"{entry.run_id}: delivered to {entry.url} (HTTP {result.status})" + (
            f"; {result.note}" if result.note else "")
    if outcome == "failed":
        return f"{entry.run_id}: refused ({result.detail}); moved to {entry.path}" + (
            f"\n  what to do: {result.advice}" if result.advice else "")
    return f"{entry.run_id}: still waiting ({result.detail})"
