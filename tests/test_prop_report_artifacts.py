"""Uploading a run's files (``robokit.report.artifact_upload``) as properties over generated run folders and server
behaviours, judged by a plain listing of the folder written here and by what a real loopback server received.

docs/reporting.md and the module: the files worth uploading are a run folder's ``*.mp4``, ``*.png``, ``*.svg``,
``*.jsonl`` two levels deep (one per name, at most 20), the video the folder's ``video.json`` names wherever it is,
and the run's config as ``config.toml``; each is POSTed on its own to ``<results url><run_id>/artifacts/`` with the
token; one line says ``artifacts: k/n uploaded to URL`` and what went wrong with each other file (a token the server
echoes never shown); ``robokit upload-artifacts`` exits 0 only when every file arrived, and says in one line when
there is nothing to send.
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from report_server import Answer, CourseServer

from robokit.cli import main
from robokit.errors import UserError
from robokit.report.artifact_upload import MAX_FILES, find_artifacts, upload_artifacts

pytest_plugins = ["report_props"]

SETTINGS = settings(max_examples=6, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
WORTH = (".mp4", ".png", ".svg", ".jsonl")
IDS = itertools.count(1)
TOKEN = "rks_up-token-7777"


def reset(server: CourseServer) -> None:
    server.requests.clear()
    server.stored.clear()
    server.store_count.clear()
    server.acked.clear()


files = st.lists(st.tuples(st.sampled_from(["", "plots/", "plots/deep/", "frames/"]),
                           st.sampled_from(["a", "b", "sort", "trace", "c3"]),
                           st.sampled_from([*WORTH, ".PNG", ".MP4", ".txt", ".json", ".npz", ".toml"])),
                 max_size=30, unique=True)


def listing(run: Path) -> dict[str, Path]:
    """The files worth uploading, by a plain walk of the disk: depth one then depth two (each in path order), the
    first file of a name wins."""
    one = [run / n for n in os.listdir(run)]
    two = [d / n for d in one if d.is_dir() for n in os.listdir(d)]
    found: dict[str, Path] = {}
    for path in sorted(one, key=str) + sorted(two, key=str):
        if path.is_file() and path.suffix.lower() in WORTH:
            found.setdefault(path.name, path)
    return found


@SETTINGS
@given(made=files, config=st.sampled_from([None, "robot.toml", "missing.toml", "robot.txt"]),
       traced=st.booleans(), video=st.sampled_from([None, "inside", "outside", "gone"]))
def test_the_files_worth_uploading_are_found_as_the_docs_say(
        folders: Any, made: list[tuple[str, str, str]], config: str | None, traced: bool, video: str | None) -> None:
    root = folders()
    run = root / "results" / "run-1"
    run.mkdir(parents=True)
    for sub, stem, ext in made:
        (run / sub).mkdir(parents=True, exist_ok=True)
        (run / sub / (stem + ext)).write_bytes(f"{sub}{stem}{ext}".encode())
    (root / "robot.toml").write_text("[world]\n", encoding="utf-8")
    (root / "robot.txt").write_text("x\n", encoding="utf-8")
    noted = None
    if video is not None:
        clip = (run / "clip_made_later.mp4") if video == "inside" else (root / "elsewhere.mp4")
        clip.write_bytes(b"mp4")
        (run / "video.json").write_text(json.dumps({"path": str(clip)}), encoding="utf-8")
        if video == "gone":
            clip.unlink()
        else:
            noted = clip
    if traced and not (run / "trace.jsonl").exists():  # its header names the config the run was made with
        header = {"kind": "header", "config_path": str(root / "robot.toml")}
        (run / "trace.jsonl").write_text(json.dumps(header) + "\n", encoding="utf-8")
    want = ({noted.name: noted} if noted else {}) | {k: v for k, v in listing(run).items()
                                                      if not noted or k != noted.name}
    named = str(root / config) if config else None
    traced = traced and "config_path" in (run / "trace.jsonl").read_text(encoding="utf-8")
    if (named and config == "robot.toml") or traced:
        want.setdefault("config.toml", root / "robot.toml")
    got = find_artifacts(run, named)
    assert dict(got) == dict(list(want.items())[:MAX_FILES])
    assert len(got) <= MAX_FILES and len({n for n, _ in got}) == len(got)


@SETTINGS
@given(answers=st.lists(st.sampled_from([201, 200, 400, 413, 500, "reset"]), min_size=1, max_size=5),
       token=st.booleans(), echo=st.booleans())
def test_each_file_is_posted_once_and_one_line_says_what_arrived(
        server: CourseServer, folders: Any, answers: list[Any], token: bool, echo: bool) -> None:
    reset(server)
    run_id = f"run-{next(IDS)}"
    root = folders()
    paths = []
    for i in range(len(answers)):
        path = root / f"f{i}.png"
        path.write_bytes(bytes([i]) * (i + 3) + "사진".encode())
        paths.append((f"f{i}.png", path))
    said = f"nope {TOKEN}" if echo else "nope"
    server.script(*[Answer(reset=True, store=False) if a == "reset" else Answer(a, said, store=False)
                    for a in answers])
    note = upload_artifacts(server.url, run_id, paths, token=TOKEN if token else None, timeout=(2.0, 5.0))
    assert len(server.requests) == len(answers)
    for rec, (name, path) in zip(server.requests, paths, strict=True):
        assert rec.path == f"/api/robotics/result/{run_id}/artifacts/"
        assert rec.headers.get("authorization") == (f"Bearer {TOKEN}" if token else None)
        assert rec.headers["content-type"].startswith("multipart/form-data")
        assert f'name="file"; filename="{name}"'.encode() in rec.body and path.read_bytes() in rec.body
    done = sum(1 for a in answers if a in (200, 201))
    problems = []
    for (name, _), a in zip(paths, answers, strict=True):
        if a == "reset":
            problems.append(f"{name}: ConnectionError")
        elif a not in (200, 201):
            problems.append(f"{name}: HTTP {a} " + (said.replace(TOKEN, "***") if token else said))
    url = f"{server.url}{run_id}/artifacts/"
    assert note == f"artifacts: {done}/{len(answers)} uploaded to {url}" + (f" ({'; '.join(problems)})"
                                                                          if problems else "")
    if token:
        assert TOKEN not in note


@settings(SETTINGS, max_examples=4)
@given(answers=st.lists(st.sampled_from([201, 500]), min_size=1, max_size=3))
def test_upload_artifacts_exits_0_only_when_every_file_arrived(
        server: CourseServer, folders: Any, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        answers: list[int]) -> None:
    reset(server)
    root = folders()
    run_id = f"run-{next(IDS)}"
    (root / run_id).mkdir()
    for i in range(len(answers)):
        (root / run_id / f"p{i}.svg").write_text("<svg/>", encoding="utf-8")
    server.script(*[Answer(a, "x", store=False) for a in answers])
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    capsys.readouterr()
    code = main(["upload-artifacts", run_id, "--url", server.url, "--dir", str(root)])
    out = capsys.readouterr().out
    assert code == (0 if all(a == 201 for a in answers) else 1)
    assert out.startswith(f"artifacts: {answers.count(201)}/{len(answers)} uploaded")
    assert all("authorization" not in r.headers for r in server.requests)


def test_upload_artifacts_says_in_one_line_when_it_cannot_send(server: CourseServer, folders: Any,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.report.artifact_upload import _cmd_upload

    reset(server)
    root = folders()
    (root / "empty").mkdir()
    (root / "full").mkdir()
    (root / "full" / "a.png").write_bytes(b"png")
    args = type("A", (), {"dir": str(root), "url": server.url, "token_env": None})
    for run, env, said in (("empty", None, "no video, plot or trace"), ("nowhere", None, "no video, plot or trace"),
                           ("full", "UNSET_TOKEN_VAR", "UNSET_TOKEN_VAR is not set")):
        a = args()
        a.run_id, a.token_env = run, env
        monkeypatch.delenv("UNSET_TOKEN_VAR", raising=False)
        with pytest.raises(UserError, match=said) as exc:
            _cmd_upload(a)
        assert "\n" not in str(exc.value)
    assert server.requests == []
    monkeypatch.setenv("ROBOKIT_TOKEN", TOKEN)  # like robokit run: $ROBOKIT_TOKEN when set
    a = args()
    a.run_id = "full"
    assert _cmd_upload(a) == 0
    assert [r.headers.get("authorization") for r in server.requests] == [f"Bearer {TOKEN}"]


@pytest.mark.parametrize("state", ["kept", "no_pose_log", "broken_pose_log"])
def test_a_replay_that_cannot_be_made_costs_the_replay_only(folders: Any, state: str) -> None:
    """The replay is made from the pose log the first time it is asked for; one already made is used as it is;
    without a pose log, or from one that cannot be read, there is none, nothing half-written is left, and the
    other files are uploaded all the same."""
    from robokit.report.artifact_upload import REPLAY_FILE, replay_file

    run = folders()
    (run / "trace.jsonl").write_text('{"kind": "header"}\n', encoding="utf-8")
    if state == "kept":
        (run / REPLAY_FILE).write_text('{"made": "earlier"}', encoding="utf-8")
    elif state == "broken_pose_log":
        (run / "poses.npz").write_bytes(b"not a pose log")
    before = sorted(p.name for p in run.iterdir())
    got = replay_file(run)
    assert sorted(p.name for p in run.iterdir()) == before  # nothing written, nothing left half-written
    if state == "kept":
        assert got == run / REPLAY_FILE and got.read_text(encoding="utf-8") == '{"made": "earlier"}'
        assert dict(find_artifacts(run)) == {REPLAY_FILE: run / REPLAY_FILE, "trace.jsonl": run / "trace.jsonl"}
    else:
        assert got is None and dict(find_artifacts(run)) == {"trace.jsonl": run / "trace.jsonl"}
