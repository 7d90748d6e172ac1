"""Outputs exist completely or not at all, under the name asked for, and a run page shows its own run.

A video that ffmpeg cannot finish (a file-size limit) or that an interrupt cuts leaves nothing under the name asked
for (an older complete file stays as it was), says so in one line naming the file, and exits 6 (130 / 143 for a
signal). Two runs rendered to the same ``-o sort.mp4``: the first run's page embeds the first run's video, judged by
its frame count against the first run's own pose log.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from robokit.record.format import RunRecord

ROOT = Path(__file__).resolve().parents[1]
ROBOKIT = [sys.executable, "-c", "import sys; from robokit.cli import main; sys.exit(main())"]

SCENE = """
[world]
max_time = {max_time}

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.3, 0, 0.6]
rgba = [0.9, 0.1, 0.1, 1]

[behaviour]
type = "record"
components = []
duration = {duration}
"""


def _robokit(cwd: Path, *args: str, limit: int | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    prefix = ["prlimit", f"--fsize={limit}"] if limit is not None else []
    return subprocess.run(prefix + ROBOKIT + list(args), cwd=cwd, capture_output=True, text=True, timeout=timeout)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _frames_of(path: Path) -> int:
    """Frames in an MP4, counted by decoding it (imageio-ffmpeg's reader)."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    next(reader)
    return sum(1 for _ in reader)


def _expected_frames(run: Path) -> int:
    """One frame per 1/30 s of the pose log, both ends (the oracle: the record's own sample times)."""
    t = RunRecord(run).poses["t"]
    return int(np.floor(t[-1] * 30 + 1e-6)) + 1


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """Two runs of different lengths in one folder: (folder, first run, second run)."""
    from robokit.cli import main

    folder = tmp_path_factory.mktemp("outputs")
    made = []
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        for duration in (0.5, 1.0):
            (folder / "scene.toml").write_text(SCENE.format(max_time=duration + 1, duration=duration))
            assert main(["run", "scene.toml", "--quiet"]) == 0
            made.append(max((folder / "results").iterdir(), key=lambda p: p.stat().st_mtime_ns))
    finally:
        os.chdir(cwd)
    assert made[0] != made[1]
    return folder, made[0], made[1]


def test_a_video_ffmpeg_cannot_finish_leaves_the_old_file_and_exits_6(runs: tuple[Path, Path, Path]) -> None:
    from robokit.cli import main

    folder, first, _ = runs
    old = folder / "limited.mp4"
    assert main(["video", str(first), "-o", str(old), "--size", "32x24", "--workers", "1"]) == 0
    before = _sha(old)
    assert old.stat().st_size < 6_000  # a complete small video fits under the limit; a larger one will not
    cut = _robokit(folder, "video", str(first), "-o", old.name, "--size", "160x120", "--workers", "1", limit=6_000)
    assert cut.returncode == 6, (cut.stdout, cut.stderr)
    lines = cut.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("robokit: warning: limited.mp4: not written"), cut.stderr
    assert "SIGXFSZ" in lines[0] and "frames," not in cut.stdout  # the reason, and no success line
    assert _sha(old) == before and _frames_of(old) == _expected_frames(first)  # the old video, whole
    assert [p.name for p in folder.glob(".*part*")] == []


@pytest.mark.slow
def test_an_interrupted_render_removes_its_partial_file_and_says_so(runs: tuple[Path, Path, Path]) -> None:
    folder, _, second = runs
    out = folder / "cut.mp4"
    proc = subprocess.Popen(ROBOKIT + ["video", str(second), "-o", out.name, "--size", "640x480", "--workers", "1"],
                            cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not list(folder.glob(".cut.mp4.part*")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)  # waits for a condition: ffmpeg has opened its temporary file
    assert proc.poll() is None, "the render ended before it could be interrupted"
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines() == [
        "robokit: interrupted (SIGINT); cut.mp4 not written; its partial file was removed"]
    assert not out.exists() and list(folder.glob(".*part*")) == [] and stdout == ""


def _children(pid: int) -> set[int]:
    """Child processes of ``pid`` (from /proc), recursively."""
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            kids = {int(k) for k in (task / "children").read_text().split()}
        except OSError:
            continue
        for kid in kids:
            out |= {kid} | _children(kid)
    return out


@pytest.mark.slow
def test_ctrl_c_at_the_terminal_stops_the_render_workers_without_a_word(runs: tuple[Path, Path, Path]) -> None:
    """SIGINT to the whole process group (what Ctrl-C at a terminal does) while two workers render: one line, the
    partial file removed, and no worker or ffmpeg left running."""
    folder, _, second = runs
    out = folder / "group.mp4"
    proc = subprocess.Popen(ROBOKIT + ["video", str(second), "-o", out.name, "--size", "640x480", "--workers", "2"],
                            cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    deadline = time.monotonic() + 120
    while not list(folder.glob(".group.mp4.part*")) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)  # waits for a condition: ffmpeg has opened its temporary file
    helpers = _children(proc.pid)
    assert proc.poll() is None and len(helpers) >= 3, helpers  # two workers and ffmpeg at least
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert stderr.strip().splitlines() == [
        "robokit: interrupted (SIGINT); group.mp4 not written; its partial file was removed"]
    assert not out.exists() and list(folder.glob(".*part*")) == []
    def running(pid: int) -> bool:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
            return state != "Z" and Path(f"/proc/{pid}/cmdline").read_bytes() != b""  # not exiting
        except OSError:
            return False

    deadline = time.monotonic() + 10
    while any(running(pid) for pid in helpers) and time.monotonic() < deadline:
        time.sleep(0.05)  # waits for a condition: the helpers, stopped by robokit, finish exiting
    assert [pid for pid in helpers if running(pid)] == []


def test_a_later_run_s_video_under_the_same_name_is_not_the_first_run_s(runs: tuple[Path, Path, Path]) -> None:
    from robokit.cli import main
    from robokit.record.page import find_video

    folder, first, second = runs
    shared = folder / "same.mp4"
    for run in (first, second):  # the README's flow: every run rendered to the same -o sort.mp4
        assert main(["video", str(run), "-o", str(shared), "--size", "32x24", "--workers", "1"]) == 0
    assert _frames_of(shared) == _expected_frames(second) != _expected_frames(first)
    assert find_video(RunRecord(second)) == shared
    own = first / "video.mp4"
    assert find_video(RunRecord(first)) == (own if own.exists() else None)  # never the second run's file


@pytest.mark.slow
def test_a_run_page_embeds_its_own_video_when_a_later_run_took_the_name(runs: tuple[Path, Path, Path]) -> None:
    folder, first, second = runs
    for run in (first, second):  # the README's flow: every run rendered to the same -o sort.mp4
        done = _robokit(folder, "video", str(run), "-o", "sort.mp4", "--size", "64x48")
        assert done.returncode == 0, done.stderr
    shared = folder / "sort.mp4"
    assert _frames_of(shared) == _expected_frames(second) != _expected_frames(first)
    page = folder / "first.html"
    done = _robokit(folder, "view", str(first), "-o", page.name, "--no-replay")
    assert done.returncode == 0, done.stderr
    src = re.search(r"id='run-video'[^>]*src='data:video/mp4;base64,([^']+)'", page.read_text(encoding="utf-8"))
    assert src is not None
    embedded = folder / "embedded.mp4"
    embedded.write_bytes(base64.b64decode(src.group(1)))
    assert _frames_of(embedded) == _expected_frames(first)  # the first run's video, rendered for its page
    assert _sha(embedded) != _sha(shared)
    again = _robokit(folder, "view", str(second), "-o", "second.html", "--no-replay")
    assert again.returncode == 0 and base64.b64encode(shared.read_bytes()).decode() in (
        folder / "second.html").read_text(encoding="utf-8")  # the second run's page embeds sort.mp4 as made


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("prlimit") is None, reason="needs prlimit (util-linux)")
def test_the_sort_video_under_a_file_size_limit_is_a_warning_and_exit_6(tmp_path: Path) -> None:
    """The real command: ``prlimit --fsize=60000 robokit run configs/sort_robot.toml --video out.mp4``."""
    env = dict(os.environ)
    done = subprocess.run(["prlimit", "--fsize=60000", *ROBOKIT, "run", str(ROOT / "configs" / "sort_robot.toml"),
                           "--video", "out.mp4"], cwd=tmp_path, capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 6, (done.stdout[-2000:], done.stderr)
    assert "warning: video out.mp4: not written: ffmpeg could not finish the video" in done.stdout
    assert "video: out.mp4:" not in done.stderr and "printed" not in done.stderr
    assert not (tmp_path / "out.mp4").exists() and list(tmp_path.glob(".*part*")) == []
    assert len(list((tmp_path / "results").glob("*/result.json"))) == 1


def test_a_still_by_frame_number_or_by_sim_time(runs: tuple[Path, Path, Path], tmp_path: Path,
                                                 capsys: pytest.CaptureFixture) -> None:
    from robokit.cli import main

    _, first, _ = runs
    last = _expected_frames(first) - 1
    shots = {}
    for name, flags in {"f6": ["--frame", "6"], "t02": ["--time", "0.2"], "fend": ["--frame", "-1"],
                        "tend": ["--time", "end"], "flast": ["--frame", str(last)]}.items():
        out = tmp_path / f"{name}.png"
        assert main(["video", str(first), *flags, "--size", "64x48", "-o", str(out)]) == 0
        shots[name] = out.read_bytes()
    printed = capsys.readouterr().out
    assert "f6.png: frame 6, the scene at t = 0.200 s" in printed  # frame 6 at 30 a second is t = 0.2 s
    assert shots["f6"] == shots["t02"] and shots["fend"] == shots["tend"] == shots["flast"]
    assert shots["f6"] != shots["fend"]  # the box is still falling at 0.2 s
    assert main(["video", str(first), "--frame", str(last + 1)]) == 2
    assert capsys.readouterr().err.strip() == (f"robokit: error: --frame {last + 1}: this run's video has frames 0 "
                                               f"to {last} (30 a second; -1 is the last)")
    assert main(["video", str(first), "--time", "soon"]) == 2
    assert "--time: expected sim seconds or 'end', got 'soon'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as usage:  # a sim time given where a frame number goes: argparse's usage error
        main(["video", str(first), "--frame", "7.9"])
    assert usage.value.code == 2
    assert "got '7.9' (for a sim time in seconds: --time 7.9)" in capsys.readouterr().err
