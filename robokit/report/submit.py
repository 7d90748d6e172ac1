"""``robokit submit ASSIGNMENT CONFIG [--plugin PATH] [--wait]``: send a config (and, where the assignment allows
it, the student's own plugin package) to the course server for official evaluation.

The server checks it (only the keys the assignment lets students change, the files it names, then robokit's own
validation) and queues it; its answer is printed in one line. Each submit sends a fresh ``Idempotency-Key`` and
sends it again if the connection fails before the answer: however often it is resent, it is one submission.
``--wait`` then follows the submission to its grade and prints each official trial's outcome and reason. Needs
only ``requests`` (no Django).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit

from robokit.errors import UserError

EXIT_NOT_GRADED, EXIT_REFUSED, EXIT_UNREACHABLE, EXIT_STILL_WAITING = 1, 2, 4, 5
SENDS = 3
"""Times a submission is sent when the connection fails before the server answers (same key each time)."""


def add_submit_command(sub: Any) -> None:
    p = sub.add_parser("submit", help="submit a config to an assignment on the course server (official evaluation)")
    p.add_argument("assignment", help="the assignment's name, as the teacher gave it")
    p.add_argument("config", help="your config (TOML)")
    p.add_argument("--url", default=os.environ.get("ROBOKIT_SERVER_URL"),
                   help="the course server, e.g. http://192.168.0.10:8000/ (default $ROBOKIT_SERVER_URL)")
    p.add_argument("--token-env", default="ROBOKIT_TOKEN", metavar="NAME",
                   help="environment variable holding your token (default ROBOKIT_TOKEN)")
    p.add_argument("--plugin", metavar="PATH", help="your own plugin, sent with the config: a module (.py) or a "
                   "package folder (only for assignments that allow students' plugins)")
    p.add_argument("--wait", action="store_true", help="follow the submission until it is graded and print each "
                   "official trial's outcome and reason")
    p.add_argument("--wait-seconds", type=float, default=3600.0, metavar="S",
                   help="with --wait: give up following after S seconds (default 3600; the evaluation goes on)")
    p.set_defaults(func=cmd_submit)


def plugin_files(path: str) -> dict[str, str]:
    """``{relative path: source}`` of a plugin module (``x.py``) or package folder (its ``*.py`` files, under the
    folder's name)."""
    root = Path(path)
    if root.is_file() and root.suffix == ".py":
        found = [(root.name, root)]
    elif root.is_dir():
        found = [(f"{root.name}/{f.relative_to(root).as_posix()}", f) for f in sorted(root.rglob("*.py"))
                 if "__pycache__" not in f.parts]
    else:
        raise UserError(f"--plugin {path}: expected a .py file or a package folder")
    if not found:
        raise UserError(f"--plugin {path}: no .py files in it")
    try:
        return {name: f.read_text(encoding="utf-8") for name, f in found}
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"--plugin {path}: {getattr(exc, 'strerror', None) or exc}") from None


def submit_url(server: str, assignment: str) -> str:
    """The submission endpoint from the server's address (a result URL ``…/api/robotics/result/`` works too)."""
    parts = urlsplit(server.strip())
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise UserError(f"--url: expected http://HOST:PORT/, got {server!r}")
    return f"{parts.scheme}://{parts.netloc}/api/robotics/assignments/{quote(assignment, safe='')}/submissions/"


def cmd_submit(args: argparse.Namespace) -> int:
    import requests

    if not args.url:
        raise UserError("--url: say where the course server is (or set ROBOKIT_SERVER_URL)")
    token = os.environ.get(args.token_env, "").strip()
    if not token:
        raise UserError(f"no token: export {args.token_env}=<the token your teacher gave you>")
    try:
        text = Path(args.config).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{args.config}: cannot read the config: {getattr(exc, 'strerror', None) or exc}") from None
    body: dict[str, Any] = {"config": text}
    if args.plugin:
        body["plugin_files"] = plugin_files(args.plugin)
    url = submit_url(args.url, args.assignment)
    headers = {"Authorization": f"Bearer {token}", "Idempotency-Key": uuid.uuid4().hex}
    resp = None
    for attempt in range(SENDS):
        try:
            resp = requests.post(url, json=body, headers=headers, timeout=60)
            break
        except requests.RequestException as exc:
            if attempt == SENDS - 1:
                print(f"robokit: error: cannot reach {url}: {type(exc).__name__}", file=sys.stderr)
                return EXIT_UNREACHABLE
            time.sleep(1.0 + attempt)
    assert resp is not None
    try:
        answer = resp.json()
    except ValueError:
        answer = {"error": f"HTTP {resp.status_code} (not JSON)"}
    accepted = resp.status_code in (200, 201)
    if not isinstance(answer, dict) or (accepted and not {"id", "assignment", "student", "seeds"} <= answer.keys()):
        # e.g. a proxy's or captive portal's page: not the course server's answer, so not a submission either
        answer, accepted = {"error": f"HTTP {resp.status_code} (not the course server's answer)"}, False
    if not accepted:
        where = args.plugin if answer.get("field") == "plugin" and args.plugin else args.config
        print(f"robokit: error: {where}: {answer.get('error') or resp.status_code}", file=sys.stderr)
        return EXIT_REFUSED
    late = " (late)" if answer.get("late") else ""
    plugins = f" with your plugin {', '.join(answer['plugins'])}" if answer.get("plugins") else ""
    print(f"submitted{late}: submission {answer['id']} of {answer['assignment']!r} for {answer['student']}{plugins}, "
          f"queued for official evaluation on {answer['seeds']} seeds", flush=True)
    if not args.wait:
        return 0
    status_url = f"{url.split('/api/robotics/')[0]}/api/robotics/submissions/{answer['id']}/"
    return follow(status_url, {"Authorization": headers["Authorization"]}, args.wait_seconds)


def follow(url: str, headers: dict[str, str], limit: float, sleep: Callable[[float], None] = time.sleep) -> int:
    """Poll a submission's state until it is graded (or fails, or ``limit`` seconds pass); print its trials and
    grade. Polls back off from 0.5 s to 5 s (x1.5 each time); a lost connection is retried until the limit."""
    import requests

    deadline, pause, last, said = time.monotonic() + limit, 0.5, "", ""
    while True:
        try:
            resp = requests.get(url, headers=headers, timeout=30)
            state = resp.json() if resp.status_code == 200 else None
        except (requests.RequestException, ValueError):
            resp, state = None, None
        if resp is not None and resp.status_code in (401, 403, 404):  # the token no longer sees it: say so once
            try:
                why = resp.json().get("error") or f"HTTP {resp.status_code}"
            except ValueError:
                why = f"HTTP {resp.status_code}"
            print(f"robokit: error: cannot follow the submission: {why}", file=sys.stderr)
            return EXIT_REFUSED
        if state is not None:
            note = state.get("note") or ""
            if state["status"] != last or note != said:
                last, said = state["status"], note
                if last in ("queued", "running"):
                    print(f"{last}{f': {note}' if note else ''}...", flush=True)
            if last in ("done", "error"):
                return report(state)
        if time.monotonic() + pause > deadline:
            print(f"robokit: error: submission still {last or 'unknown'} after {limit:g} s; it stays queued: see "
                  f"'/me/' or run with --wait again later", file=sys.stderr)
            return EXIT_STILL_WAITING
        sleep(pause)
        pause = min(pause * 1.5, 5.0)


def report(state: dict[str, Any]) -> int:
    """Print a finished submission: one line per official trial, then its grade."""
    for t in state.get("trials") or []:
        reason = f" - {t['reason']}" if t.get("reason") else ""
        print(f"  seed {t['seed']}: {t['outcome']}{reason}")
    if state["status"] == "error":
        print(f"robokit: error: submission {state['id']} could not be evaluated: {state.get('error') or 'error'}",
              file=sys.stderr)
        return EXIT_NOT_GRADED
    low, high = state.get("wilson95") or (None, None)
    rate = state.get("success_rate")
    bounds = f", 95 % {low:.2f}-{high:.2f}" if low is not None and high is not None else ""
    print(f"graded: {state.get('succeeded')}/{len(state.get('trials') or [])} official trials succeeded "
          f"(success rate {rate if rate is None else f'{rate:.2f}'}{bounds})")
    return 0
