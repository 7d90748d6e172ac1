"""Post a training log to the course server, where the student's dashboard plots it.

::

    python -m robokit.gym.post runs/train/reach-ppo-s0/progress.jsonl --report-url http://host:8000/api/robotics/result/
    python -m robokit.gym.train configs/gym/reach.toml --report-url http://host:8000/api/robotics/result/

The URL is the one ``robokit run --report-url`` takes (the server's results URL); the log goes to the training
endpoint beside it (``/api/robotics/training/``) with the token in ``$ROBOKIT_TOKEN`` (or ``--token-env NAME``).
The log is the ``progress.jsonl`` that ``python -m robokit.gym.train`` writes (one line per rollout: ``env_steps``,
``episodes``, ``return_mean``, ``success_rate``), or any JSON lines with ``steps`` and any of ``episodes``,
``return``, ``success_rate``. Its run id is the log's SHA-256: posting the same log again stores nothing new.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

TRAINING_PATH = "/api/robotics/training/"
RESULTS_PATH = "/api/robotics/result/"
DEFAULT_TOKEN_ENV = "ROBOKIT_TOKEN"


class PostError(Exception):
    """The log could not be posted: one line saying why."""


def training_url(url: str) -> str:
    """The training endpoint for a server's results URL (``…/api/robotics/result/``), its root, or the training
    endpoint itself.

    Raises:
        PostError: a URL that is none of those.
    """
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise PostError(f"--report-url {url!r}: expected http(s)://HOST[:PORT]{RESULTS_PATH}")
    path = parts.path.rstrip("/") + "/"
    for known in (RESULTS_PATH, TRAINING_PATH):
        if path.endswith(known):
            path = path[: -len(known)]
            break
    else:
        if path != "/":
            raise PostError(f"--report-url {url!r}: expected the course server's results URL "
                            f"(…{RESULTS_PATH}, the one robokit run --report-url takes)")
        path = ""
    return urlunsplit((parts.scheme, parts.netloc, path.rstrip("/") + TRAINING_PATH, "", ""))


def post_log(url: str, log: str, *, name: str, token: str, timeout: float = 30.0) -> str:
    """POST ``log`` (JSON lines) as a training run called ``name``; returns the one line to print.

    Raises:
        PostError: the server refused it or could not be reached (the server's reason, never the token).
    """
    import requests

    target = training_url(url)
    body = {"name": name[:100], "run_id": hashlib.sha256(log.encode("utf-8")).hexdigest()[:32], "log": log}
    try:
        resp = requests.post(target, json=body, headers={"Authorization": f"Bearer {token}"}, timeout=timeout)
    except requests.RequestException as exc:
        raise PostError(f"{target}: {type(exc).__name__}; the log is still in your run folder") from None
    if resp.status_code in (200, 201):
        answer = resp.json()
        again = " (already there)" if resp.status_code == 200 else ""
        return f"training log posted{again}: {answer.get('points')} points as {answer.get('name')!r} for " \
               f"{answer.get('student')} at {target}"
    try:
        reason = str(resp.json().get("error", ""))
    except ValueError:
        reason = " ".join(resp.text.split())[:200]
    raise PostError(f"{target}: HTTP {resp.status_code} {reason.replace(token, '***')}")


def token_from(env_name: str | None) -> str:
    """The token in ``$env_name`` (default ``$ROBOKIT_TOKEN``).

    Raises:
        PostError: the variable is not set.
    """
    name = env_name or DEFAULT_TOKEN_ENV
    token = os.environ.get(name, "").strip()
    if not token:
        raise PostError(f"environment variable {name} is not set: export {name}=... (the token your teacher gave "
                        "you)")
    return token


def post_file(path: Path, url: str, *, name: str | None = None, token_env: str | None = None) -> str:
    """Post the log file ``path`` (named after its folder unless ``name`` is given)."""
    token = token_from(token_env)
    try:
        log = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise PostError(f"{path}: {exc.strerror or exc}") from None
    return post_log(url, log, name=name or path.resolve().parent.name, token=token)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m robokit.gym.post", description="Post a training log to the course "
                                "server (plotted on your dashboard).")
    p.add_argument("log", type=Path, help="the log, e.g. runs/train/reach-ppo-s0/progress.jsonl")
    p.add_argument("--report-url", required=True, help="the course server's results URL (as for robokit run)")
    p.add_argument("--name", help="the run's name on the dashboard (default: the log's folder name)")
    p.add_argument("--token-env", metavar="NAME", help=f"variable holding your token (default {DEFAULT_TOKEN_ENV})")
    args = p.parse_args(argv)
    try:
        print(post_file(args.log, args.report_url, name=args.name, token_env=args.token_env))
    except PostError as exc:
        print(f"post: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
