"""Uploading a run's files (video, plots, trace, config, 3D replay) to the course server, after its result arrived.

The server takes them at ``POST <results url><run_id>/artifacts/`` (multipart). Used by the ``http`` reporter's
``upload_artifacts = true`` and by ``robokit upload-artifacts`` (for a video or plot made after the run).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

SUFFIXES = (".mp4", ".png", ".svg", ".jsonl")
MAX_FILES = 20


def find_artifacts(run_dir: str | Path, config: Any = None) -> list[tuple[str, Path]]:
    """``(upload name, path)`` of the files worth uploading from a run folder (two levels deep); the video
    ``robokit video`` / ``robokit run --video FILE`` last made of the run wherever it was written (the run
    folder's ``video.json`` names it); the 3D replay's data (``replay.json``, see :func:`replay_file`); and the
    run's config file when ``config`` names a TOML file that exists (uploaded as ``config.toml``)."""
    folder = Path(run_dir)
    found: dict[str, Path] = {}
    for extra in (_noted_video(folder), replay_file(folder)):
        if extra is not None:
            found[extra.name] = extra
    if folder.is_dir():
        for path in sorted(folder.glob("*")) + sorted(folder.glob("*/*")):
            if path.is_file() and path.suffix.lower() in SUFFIXES and path.name not in found:
                found[path.name] = path
    for source in (config, _recorded_config(folder)):  # a payload names its config relative or by name alone
        if isinstance(source, str) and source.endswith(".toml") and Path(source).is_file():
            found.setdefault("config.toml", Path(source))
    return list(found.items())[:MAX_FILES]


def _recorded_config(folder: Path) -> str | None:
    """The config file the run's trace header names (``config_path``), if the record has a header."""
    import json

    try:
        with (folder / "trace.jsonl").open(encoding="utf-8") as f:
            header = json.loads(f.readline())
    except (OSError, ValueError):
        return None
    path = header.get("config_path") if isinstance(header, dict) else None
    return path if isinstance(path, str) else None


def _noted_video(folder: Path) -> Path | None:
    """The MP4 the run folder's ``video.json`` names, when it still exists and is still this run's video."""
    from robokit.record.layout import noted_video

    return noted_video(folder, undigested=True)


REPLAY_FILE = "replay.json"


def replay_file(folder: Path) -> Path | None:
    """The run's 3D replay as the server's run page draws it (``replay.json``: the data ``robokit view``'s page
    embeds), written into the run folder from its pose log the first time it is asked for; None when the record
    has no pose log or its scene cannot be rebuilt here (the other files are uploaded all the same)."""
    import json

    out = folder / REPLAY_FILE
    if out.is_file():
        return out
    if not (folder / "poses.npz").is_file():
        return None
    from robokit.record.format import RunRecord
    from robokit.record.replay import payload

    tmp = folder / (REPLAY_FILE + ".tmp")
    try:
        text = json.dumps(payload(RunRecord(folder)), separators=(",", ":"), allow_nan=False)
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(out)
    except Exception:  # noqa: BLE001 - a replay that cannot be made costs the replay only, never the upload
        tmp.unlink(missing_ok=True)
        return None
    return out


def artifacts_url(results_url: str, run_id: str) -> str:
    return f"{results_url.rstrip('/')}/{run_id}/artifacts/"


def upload_artifacts(results_url: str, run_id: str, files: list[tuple[str, Path]], *, token: str | None = None,
                     verify: bool | str = True, timeout: tuple[float, float] = (3.05, 60.0)) -> str:
    """Upload ``files`` one request each; returns one line saying what happened (never the token)."""
    import requests

    from robokit import __version__

    url = artifacts_url(results_url, run_id)
    headers = {"User-Agent": f"robokit/{__version__}"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    done, problems = 0, []
    with requests.Session() as session:
        session.trust_env = True
        for name, path in files:
            try:
                with path.open("rb") as fh:
                    resp = session.post(url, files={"file": (name, fh)}, headers=headers, timeout=timeout,
                                        verify=verify, allow_redirects=False)
            except (OSError, requests.RequestException) as exc:
                problems.append(f"{name}: {type(exc).__name__}")
                continue
            if 200 <= resp.status_code < 300:
                done += 1
            else:
                text = resp.text.replace(token, "***") if token else resp.text
                problems.append(f"{name}: HTTP {resp.status_code} {' '.join(text.split())[:120]}")
    note = f"artifacts: {done}/{len(files)} uploaded to {url}"
    return note + (f" ({'; '.join(problems)})" if problems else "")


def add_upload_command(sub: Any) -> None:
    """``robokit upload-artifacts RUN_ID --url URL``: send a run folder's files (e.g. a video made later)."""
    cmd = sub.add_parser("upload-artifacts", help="upload a run folder's video, plots and trace to the course server")
    cmd.add_argument("run_id", help="the run id (its folder is <dir>/<run_id>/)")
    cmd.add_argument("--url", required=True, help="the results URL, e.g. http://host/api/robotics/result/")
    cmd.add_argument("--dir", default="results", help="folder holding run folders (default results)")
    cmd.add_argument("--token-env", metavar="NAME", help="environment variable holding your token (default: "
                     "ROBOKIT_TOKEN when set)")
    cmd.set_defaults(func=_cmd_upload)


def _cmd_upload(args: Any) -> int:
    import os

    from robokit.errors import UserError

    folder = Path(args.dir) / args.run_id
    files = find_artifacts(folder)
    if not files:
        raise UserError(f"{folder}: no video, plot or trace to upload (*.mp4, *.png, *.svg, *.jsonl)")
    token = os.environ.get(args.token_env or "ROBOKIT_TOKEN") or None  # like robokit run: $ROBOKIT_TOKEN when set
    if args.token_env and not token:
        raise UserError(f"environment variable {args.token_env} is not set")
    note = upload_artifacts(args.url, args.run_id, files, token=token)
    print(note)
    return 0 if note.startswith(f"artifacts: {len(files)}/") else 1
