"""``robokit outbox list | flush``: see and deliver results that wait in the outbox.

Exit codes of ``robokit outbox flush``: 0 every waiting entry was delivered (or none waited); 1 some entries are
still waiting or were refused (moved to ``failed/``). ``robokit outbox list`` exits 0.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

DEFAULT_DIR = "outbox"


def add_outbox_command(sub: Any) -> None:
    """Add ``outbox`` with its ``list`` and ``flush`` subcommands to the CLI's subparsers."""
    box = sub.add_parser("outbox", help="list or deliver results waiting in the outbox")
    cmds = box.add_subparsers(dest="outbox_command", metavar="ACTION")
    cmds.required = True

    lst = cmds.add_parser("list", help="show waiting results: run id, age, attempts, last error")
    lst.add_argument("--dir", help=f"outbox folder (default: ./{DEFAULT_DIR})")
    lst.add_argument("--json", action="store_true", help="print the entries as JSON (without payloads)")
    lst.add_argument("--failed", action="store_true", help="show the entries in failed/ (refused by the server)")
    lst.set_defaults(func=cmd_list)

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


def _row(entry: Any) -> dict[str, Any]:
    return {"run_id": entry.run_id, "age_s": round(entry.age, 1), "attempts": entry.attempts,
            "last_error": entry.last_error, "url": entry.url, "created": entry.data.get("created")}


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
    """Print what waits (oldest first), then how many entries were refused and sit in ``failed/``."""
    from robokit.report.outbox import Outbox

    box = Outbox(_folder(args))
    waiting, failed, broken = box.entries(), box.failed(), box.unreadable()
    if args.json:
        print(json.dumps({"dir": str(box.root), "waiting": [_row(e) for e in waiting],
                          "failed": [_row(e) for e in failed],
                          "unreadable": [{"path": str(p), "why": why} for p, why in broken]}, indent=2))
        return 0
    shown = failed if args.failed else waiting
    if shown:
        print(f"{'RUN ID':<36}  {'AGE':>7}  {'ATTEMPTS':>8}  {'SERVER ANSWER' if args.failed else 'LAST ERROR'}")
    for e in shown:
        print(f"{e.run_id:<36}  {_age(e.age):>7}  {e.attempts:>8}  {e.last_error or '-'}")
    print(f"{len(waiting)} waiting in {box.root}; {len(failed)} refused in {box.failed_dir}")
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
