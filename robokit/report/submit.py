"""``robokit submit ASSIGNMENT CONFIG [--plugin PATH]``: send a config (and, where the assignment allows it, the
student's own plugin package) to the course server for official evaluation.

The server checks it (only the keys the assignment lets students change, then robokit's own validation) and queues
it; its answer is printed in one line. Needs only ``requests`` (no Django).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit

from robokit.errors import UserError

EXIT_REFUSED, EXIT_UNREACHABLE = 2, 4


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
    try:
        resp = requests.post(url, json=body, headers={"Authorization": f"Bearer {token}"}, timeout=60)
    except requests.RequestException as exc:
        print(f"robokit: error: cannot reach {url}: {type(exc).__name__}", file=sys.stderr)
        return EXIT_UNREACHABLE
    try:
        answer = resp.json()
    except ValueError:
        answer = {"error": f"HTTP {resp.status_code} (not JSON)"}
    if resp.status_code != 201:
        where = args.plugin if answer.get("field") == "plugin" else args.config
        print(f"robokit: error: {where}: {answer.get('error') or resp.status_code}", file=sys.stderr)
        return EXIT_REFUSED
    late = " (late)" if answer.get("late") else ""
    plugins = f" with your plugin {', '.join(answer['plugins'])}" if answer.get("plugins") else ""
    print(f"submitted{late}: submission {answer['id']} of {answer['assignment']!r} for {answer['student']}{plugins}, "
          f"queued for official evaluation on {answer['seeds']} seeds")
    return 0
