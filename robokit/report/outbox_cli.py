"""``robokit outbox list | flush | retry``: see, deliver and re-send results that wait in the outbox.

Exit codes of ``robokit outbox flush`` and ``retry``: 0 every entry taken was delivered (or none was there to take;
waiting entries made under another token are left waiting and do not count); 1 some entries are still waiting or
were refused (moved to ``failed/``), including a refused entry ``retry`` leaves because another token made it
(``--claim`` takes it). ``robokit outbox list`` exits 0.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

DEFAULT_DIR = "outbox"


def add_outbox_command(sub: Any) -> None:
    """Add ``outbox`` with its ``list`` and ``flush`` subcommands to the CLI's subparsers."""
    box = sub.add_parser("outbox", help="list or deliver results waiting in the outbox")
    cmds = box.add_subparsers(dest="outbox_command", metavar="ACTION")
    cmds.required = True

    lst = cmds.add_parser("list", help="show every entry: state (waiting / refused), whose, age, attempts, why")
    lst.add_argument("--dir", help=f"outbox folder (default: ./{DEFAULT_DIR})")
    lst.add_argument("--json", action="store_true", help="print the entries as JSON (without payloads)")
    lst.add_argument("--failed", action="store_true", help="only the entries in failed/ (refused by the server)")
    lst.add_argument("--token-env", metavar="NAME", help="whose token you are (default: ROBOKIT_TOKEN)")
    lst.set_defaults(func=cmd_list)

    retry = cmds.add_parser("retry", help="put refused results back and send them again (after fixing the cause)")
    retry.add_argument("runs", nargs="*", metavar="RUN", help="run ids (or prefixes); default: every refused entry")
    retry.add_argument("--dir", help=f"outbox folder (default: ./{DEFAULT_DIR})")
    retry.add_argument("--token-env", metavar="NAME",
                       help="read the bearer token from this environment variable instead of the entry's")
    retry.add_argument("--project", help="set the result's project before sending it again")
    retry.add_argument("--student", help="set the result's student before sending it again")
    retry.add_argument("--claim", action="store_true",
                       help="also take entries made under another token (yours, e.g. after a new token was issued)")
    retry.set_defaults(func=cmd_retry)

    flush = cmds.add_parser("flush", help="deliver waiting results, oldest first")
    flush.add_argument("--dir", help=f"outbox folder (default: ./{DEFAULT_DIR})")
    flush.add_argument("--url", help="send every entry to this URL instead of the one it was made for")
    flush.add_argument("--token-env", metavar="NAME",
                       help="read the bearer token from this environment variable instead of the entry's")
    flush.add_argument("--keep-going", action="store_true",
                       help="try every entry even after one fails for a passing reason (server down, 5xx)")
    flush.set_defaults(func=cmd_flush)


def _age(seconds: float) -> str:
    """``42s``, ``3m07s``, ``5h02m``, ``2d03h``."""
    s = int(seconds)
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    if s < 86400:
        return f"{s // 3600}h{s % 3600 // 60:02d}m"
    return f"{s // 86400}d{s % 86400 // 3600:02d}h"


def _row(entry: Any, state: str = "waiting") -> dict[str, Any]:
    return {"run_id": entry.run_id, "state": state, "identity": entry.identity, "age_s": round(entry.age, 1),
            "attempts": entry.attempts, "last_error": entry.last_error, "advice": entry.data.get("advice"),
            "url": entry.url, "created": entry.data.get("created")}


def _whose(identity: str, mine: str) -> str:
    return "yours" if identity == mine else identity


def _folder(args: argparse.Namespace) -> Path:
    """The outbox folder: ``--dir`` must be an existing folder; the default ``./outbox`` may be missing (nothing
    was ever queued)."""
    from robokit.errors import UserError

    if args.dir is None:
        path = Path(DEFAULT_DIR)
        if path.exists() and not path.is_dir():
            raise UserError(f"outbox {path}: is not a folder")
        return path
    path = Path(args.dir)
    if not path.exists():
        raise UserError(f"--dir {path}: no such folder")
    if not path.is_dir():
        raise UserError(f"--dir {path}: is not a folder")
    return path


def cmd_list(args: argparse.Namespace) -> int:
    """Print every entry (oldest first): its state, whose it is, age, attempts and why it waits or was refused."""
    from robokit_plugins.http_report import DEFAULT_TOKEN_ENV

    from robokit.report.outbox import Outbox, fingerprint

    box = Outbox(_folder(args))
    waiting, failed, broken = box.entries(), box.failed(), box.unreadable()
    mine = fingerprint(os.environ.get(args.token_env or DEFAULT_TOKEN_ENV))
    if args.json:
        print(json.dumps({"dir": str(box.root), "you": mine, "waiting": [_row(e) for e in waiting],
                          "failed": [_row(e, "refused") for e in failed],
                          "unreadable": [{"path": str(p), "why": why} for p, why in broken]}, indent=2))
        return 0
    shown = [("refused", e) for e in failed] if args.failed else \
        [("waiting", e) for e in waiting] + [("refused", e) for e in failed]
    if shown:
        print(f"{'RUN ID':<36}  {'STATE':<7}  {'WHOSE':<19}  {'AGE':>7}  {'ATTEMPTS':>8}  WHY")
    for state, e in shown:
        why = e.last_error or "-"
        if e.data.get("advice"):
            why += f" - {e.data['advice']}"
        print(f"{e.run_id:<36}  {state:<7}  {_whose(e.identity, mine):<19}  {_age(e.age):>7}  {e.attempts:>8}  {why}")
    print(f"{len(waiting)} waiting in {box.root}; {len(failed)} refused in {box.failed_dir} (you: {mine}); "
          "`robokit outbox flush` sends yours, `robokit outbox retry` re-sends refused ones")
    for path, why in broken:
        print(f"warning: {path}: {why}")
    return 0


def cmd_flush(args: argparse.Namespace) -> int:
    """Deliver oldest first; print one line per entry and a count. Exit 0 only if nothing is left waiting."""
    from robokit_plugins.http_report import HttpSender, url_problem

    from robokit.errors import UserError
    from robokit.report.outbox import Outbox, OutboxError

    if args.url is not None and url_problem(args.url):
        raise UserError(f"--url {args.url!r}: {url_problem(args.url)}")
    box = Outbox(_folder(args))
    sender = HttpSender(url=args.url, token_env=args.token_env)
    try:
        report = box.flush(sender, stop_on_transient=not args.keep_going)
    except OutboxError as exc:  # a filesystem problem, said as such
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"outbox {box.root}: {exc.strerror or exc}") from None
    finally:
        sender.close()
    for line in report.lines:
        print(line)
    if report.not_tried:
        print(f"{len(report.not_tried)} newer entries for a server that just failed were not tried "
              "(use --keep-going to try them)")
    print(f"outbox {box.root}: {report.counts()}")
    return 0 if report.clean else 1


def cmd_retry(args: argparse.Namespace) -> int:
    """Put refused entries (and, with ``--claim``, entries of another token) back, bound to you, and send them."""
    from robokit_plugins.http_report import HttpSender

    from robokit.errors import UserError
    from robokit.report.outbox import NO_TOKEN, Outbox, OutboxError

    box = Outbox(_folder(args))
    sender = HttpSender(token_env=args.token_env)
    chosen = _chosen(box, args.runs, claim=args.claim)
    taken: set[str] = set()
    try:
        for entry in chosen:
            mine = sender.identity(entry)
            if entry.identity not in (mine, NO_TOKEN) and not args.claim:
                print(f"{entry.run_id}: made under token {entry.identity}, not yours ({mine}): left as it is "
                      "(`--claim` takes it if it is yours, e.g. after your teacher issued you a new token)")
                continue
            with box.lock(entry.run_id):
                box.restore(entry, mine, _patched(entry.payload, args))
            taken.add(entry.run_id)
        if not taken:
            print("nothing to retry" + ("" if chosen else f": no refused entry in {box.failed_dir}"))
            return 0 if not chosen else 1
        report = box.flush(sender, stop_on_transient=False, only=taken)
    except OutboxError as exc:
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"outbox {box.root}: {exc.strerror or exc}") from None
    finally:
        sender.close()
    for line in report.lines:
        print(line)
    print(f"outbox {box.root}: {report.counts()}")
    return 0 if report.clean and {e.run_id for e in chosen} <= taken else 1  # one left for another token: still refused


def _chosen(box: Any, runs: list[str], *, claim: bool) -> list[Any]:
    """The entries ``retry`` takes: refused ones (and waiting ones with ``--claim`` or when named), by run id or
    prefix; a name that matches nothing or several is an error."""
    from robokit.errors import UserError

    candidates = box.failed() + (box.entries() if claim or runs else [])
    if not runs:
        return candidates
    chosen = []
    for run in runs:
        hits = [e for e in candidates if e.run_id.startswith(run)]
        if len({e.run_id for e in hits}) != 1:
            what = "no refused or waiting entry" if not hits else f"{len(hits)} entries"
            raise UserError(f"robokit outbox retry {run}: {what} in {box.root} (match by run id or its start)")
        chosen.append(hits[0])
    return chosen


def _patched(payload: dict[str, Any], args: argparse.Namespace) -> dict[str, Any] | None:
    """The payload with ``--project`` / ``--student`` applied, or None when neither was given."""
    if args.project is None and args.student is None:
        return None
    out = dict(payload)
    for key in ("project", "student"):
        if getattr(args, key) is not None:
            out[key] = getattr(args, key)
    return out
