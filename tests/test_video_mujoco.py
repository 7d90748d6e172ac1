"""A MuJoCo run's video is drawn by MuJoCo (``mujoco.Renderer`` through EGL), from the record, with the PyBullet
path's camera, overlay, frame count and checks; ``--renderer`` chooses; a MuJoCo that cannot render is one line.

Oracles: where the record's poses put the box (and PyBullet's own forward kinematics puts the arm's links), projected
through a pinhole camera computed here from the ``--view`` numbers, against the pixels ffmpeg decodes from the file.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
pytest.importorskip("mujoco")

from robokit.cli import main  # noqa: E402
from robokit.record.format import RunRecord, find_run  # noqa: E402
from robokit.record.layout import VIDEO_NOTE  # noqa: E402
from robokit.record.video import frame_bytes, frame_indices, render_video  # noqa: E402

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.6, -0.4, 0.6]
rgba = [0.9, 0.1, 0.1, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
[actuators.joints.sine.lbr_iiwa_joint_2]
amplitude = 0.8
frequency_hz = 1.0

[behaviour]
type = "record"
components = []
duration = 1.2
"""
"""The box falls 0.5 m onto the floor while the arm swings: both move across the picture."""

EYE, TARGET, FOV, SIZE = (2.2, -2.2, 1.6), (0.2, 0.0, 0.4), 50.0, (320, 240)
VIEW = ",".join(f"{v:g}" for v in (*EYE, *TARGET))
CHECKED = (0, 18, 36)
"""Video frames looked at: the start, the middle and the last (1.2 s at 30 frames a second: 37 frames)."""


def _run(folder: Path, engine: str) -> Path:
    folder.mkdir()
    (folder / "scene.toml").write_text(SCENE)
    with contextlib.chdir(folder):
        assert main(["run", "scene.toml", "--quiet", "--engine", engine]) == 0
        return find_run("last").folder.resolve()


@pytest.fixture(scope="module")
def mujoco_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder of the scene on MuJoCo (read by every test; each writes its own outputs elsewhere)."""
    return _run(tmp_path_factory.mktemp("video_mujoco") / "mujoco", "mujoco")


@pytest.fixture(scope="module")
def pybullet_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder of the same scene on PyBullet."""
    return _run(tmp_path_factory.mktemp("video_pybullet") / "pybullet", "pybullet")


def pixel(point: np.ndarray) -> tuple[int, int]:
    """(column, row) of a world point through a pinhole camera at EYE looking at TARGET, z up, FOV vertical."""
    eye = np.asarray(EYE)
    ahead = np.asarray(TARGET) - eye
    ahead /= np.linalg.norm(ahead)
    right = np.cross(ahead, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, ahead)
    d = np.asarray(point, float) - eye
    focal = SIZE[1] / 2 / math.tan(math.radians(FOV) / 2)
    return int(SIZE[0] / 2 + focal * (d @ right) / (d @ ahead)), int(SIZE[1] / 2 - focal * (d @ up) / (d @ ahead))


def decoded(path: Path) -> list[np.ndarray]:
    """Every frame ffmpeg decodes from an MP4, RGB."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    assert tuple(meta["size"]) == SIZE
    return [np.frombuffer(f, np.uint8).reshape(SIZE[1], SIZE[0], 3) for f in reader]


def patch(frame: np.ndarray, at: tuple[int, int]) -> np.ndarray:
    """Median colour of the 3x3 pixels round (column, row)."""
    col, row = at
    return np.median(frame[row - 1:row + 2, col - 1:col + 2].reshape(-1, 3), axis=0)


def red(colour: np.ndarray) -> bool:
    r, g, b = (float(v) for v in colour)
    return r > 60 and r > 2.5 * g and r > 2.5 * b


def arm_points(rec: RunRecord, sample: int) -> list[np.ndarray]:
    """World positions of the KUKA's link frames 2 to 6 at one pose sample, by PyBullet's own forward kinematics of
    the recorded joints (a second computation: the MuJoCo scene is not asked)."""
    import pybullet as p
    import pybullet_data

    client = p.connect(p.DIRECT)
    try:
        kuka = p.loadURDF(f"{pybullet_data.getDataPath()}/kuka_iiwa/model.urdf", useFixedBase=True,
                          physicsClientId=client)
        index = {p.getJointInfo(kuka, j, physicsClientId=client)[1].decode(): j
                 for j in range(p.getNumJoints(kuka, physicsClientId=client))}
        names = rec.header["bodies"]["kuka"]["joints"]
        for name, q in zip(names, rec.poses["joints/kuka"][sample].tolist(), strict=True):
            p.resetJointState(kuka, index[name], q, physicsClientId=client)
        return [np.asarray(p.getLinkState(kuka, link, physicsClientId=client)[4]) for link in range(2, 7)]
    finally:
        p.disconnect(client)


def check_box(rec: RunRecord, frames: list[np.ndarray]) -> None:
    """The red box is drawn where the record puts it in each checked frame, and no longer where it was."""
    samples = frame_indices(rec.poses["t"], 30.0)
    at = {k: pixel(rec.poses["base/box"][samples[k], :3]) for k in CHECKED}
    assert at[36][1] - at[0][1] > 20  # it fell across the picture: the frames can tell the places apart
    for k in CHECKED:
        assert red(patch(frames[k], at[k])), (k, at[k], patch(frames[k], at[k]))
    assert not red(patch(frames[36], at[0]))


@pytest.mark.slow
def test_a_mujoco_runs_video_is_drawn_by_mujoco_with_the_box_and_arm_where_the_record_says(
        mujoco_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mj.mp4"
    assert main(["video", str(mujoco_run), "-o", str(out), "--size", "320x240", "--view", VIEW,
                 "--workers", "2"]) == 0  # auto: the engine that ran
    printed = capsys.readouterr()
    assert "drawn by mujoco" in printed.out and "note" not in printed.err
    rec = RunRecord(mujoco_run)
    frames = decoded(out)
    assert len(frames) == round(1.2 * 30) + 1 == len(frame_indices(rec.poses["t"], 30.0))  # both ends of 1.2 s
    note = json.loads((mujoco_run / VIDEO_NOTE).read_text())
    assert note["renderer"] == "mujoco" and note["frames"] == len(frames)
    check_box(rec, frames)
    # MuJoCo draws its floor in one flat grey: the arm's links are where their pixels are not that grey
    samples = frame_indices(rec.poses["t"], 30.0)
    tips = {}
    for k in CHECKED:
        floor = np.median(frames[k].reshape(-1, 3), axis=0)
        points = arm_points(rec, samples[k])
        tips[k] = pixel(points[-1])
        for point in points:
            seen = patch(frames[k], pixel(point))
            assert np.abs(seen - floor).max() > 25, (k, pixel(point), seen, floor)
    assert math.dist(tips[0], tips[36]) > 25  # the arm swung: its tip was elsewhere at the start
    floor = np.median(frames[36].reshape(-1, 3), axis=0)
    assert np.abs(patch(frames[36], tips[0]) - floor).max() < 12  # ... and is drawn there no longer


@pytest.mark.slow
def test_the_same_mujoco_record_drawn_by_pybullet_on_request_puts_the_box_in_the_same_places(
        mujoco_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pb.mp4"
    assert main(["video", str(mujoco_run), "-o", str(out), "--size", "320x240", "--view", VIEW,
                 "--renderer", "pybullet"]) == 0
    assert "drawn by pybullet" in capsys.readouterr().out
    frames = decoded(out)
    assert len(frames) == 37
    check_box(RunRecord(mujoco_run), frames)
    assert json.loads((mujoco_run / VIDEO_NOTE).read_text())["renderer"] == "pybullet"


@pytest.mark.slow
def test_a_pybullet_run_drawn_by_mujoco_on_request_puts_the_box_where_the_record_says(
        pybullet_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mj.mp4"
    assert main(["video", str(pybullet_run), "-o", str(out), "--size", "320x240", "--view", VIEW,
                 "--renderer", "mujoco"]) == 0
    assert "drawn by mujoco" in capsys.readouterr().out
    frames = decoded(out)
    assert len(frames) == 37
    check_box(RunRecord(pybullet_run), frames)


@pytest.mark.slow
def test_mujoco_frames_are_the_same_bytes_in_every_render_and_with_any_number_of_workers(
        mujoco_run: Path, tmp_path: Path) -> None:
    rec = RunRecord(mujoco_run)
    size = (160, 120)
    one = list(frame_bytes(rec, fps=30.0, size=size, view=None, workers=1, engine="mujoco"))
    two = list(frame_bytes(rec, fps=30.0, size=size, view=None, workers=2, engine="mujoco"))
    assert len(one) == len(two) == 37
    assert [k for k, (a, b) in enumerate(zip(one, two, strict=True)) if a != b] == []
    assert one[0] != one[-1]
    files = [tmp_path / "a.mp4", tmp_path / "b.mp4"]
    stats = [render_video(rec, f, size=size, fps=20.0, workers=2, renderer="mujoco") for f in files]
    assert files[0].read_bytes() == files[1].read_bytes()
    assert [s.frames for s in stats] == [round(1.2 * 20) + 1] * 2 and stats[0].renderer == "mujoco"


@pytest.mark.slow
def test_a_still_of_a_mujoco_run_is_that_video_frame_drawn_by_mujoco(
        mujoco_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import cv2

    out = tmp_path / "f18.png"
    assert main(["video", str(mujoco_run), "--frame", "18", "-o", str(out), "--size", "160x120"]) == 0
    assert "frame 18, the scene at t = 0.600 s, 160x120, drawn by mujoco" in capsys.readouterr().out
    still = cv2.cvtColor(cv2.imread(str(out)), cv2.COLOR_BGR2RGB)
    frames = list(frame_bytes(RunRecord(mujoco_run), fps=30.0, size=(160, 120), view=None, workers=1,
                              engine="mujoco"))
    assert still.tobytes() == frames[18]


@pytest.mark.slow
def test_run_with_video_on_mujoco_has_mujoco_draw_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(SCENE)
    assert main(["run", "scene.toml", "--engine", "mujoco", "--video", "run.mp4"]) == 0
    assert "video: run.mp4: 37 frames at 30 fps, drawn by mujoco" in capsys.readouterr().err
    note = json.loads((find_run("last").folder / VIDEO_NOTE).read_text())
    assert note["renderer"] == "mujoco" and note["frames"] == len(decoded_any(tmp_path / "run.mp4")) == 37


def _cli(args: list[str], cwd: Path, **env: str | None) -> subprocess.CompletedProcess[str]:
    environment = {k: v for k, v in os.environ.items() if k not in env}
    environment.update({k: v for k, v in env.items() if v is not None})
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], cwd=cwd, env=environment,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["bogus", "glfw"])
def test_mujoco_that_cannot_render_is_one_line_and_auto_draws_with_pybullet_saying_so(
        mujoco_run: Path, tmp_path: Path, backend: str) -> None:
    # bogus: MuJoCo's import refuses it; glfw without a display: no OpenGL context can be made
    asked = _cli(["video", str(mujoco_run), "-o", "x.mp4", "--size", "96x72", "--renderer", "mujoco"], tmp_path,
                 MUJOCO_GL=backend, DISPLAY=None, WAYLAND_DISPLAY=None)
    assert asked.returncode == 2, asked.stderr
    lines = asked.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"robokit: error: --renderer mujoco: MuJoCo cannot render here (MUJOCO_GL={backend}: "), lines
    assert lines[0].endswith("use --renderer pybullet")
    assert not (tmp_path / "x.mp4").exists()
    auto = _cli(["video", str(mujoco_run), "-o", "y.mp4", "--size", "96x72", "--workers", "1"], tmp_path,
                MUJOCO_GL=backend, DISPLAY=None, WAYLAND_DISPLAY=None)
    assert auto.returncode == 0, auto.stderr
    assert auto.stderr.strip().splitlines() == [
        f"robokit: note: drawn by PyBullet: the run ran on MuJoCo, which cannot render here (MUJOCO_GL={backend}: "
        + auto.stderr.split(f"(MUJOCO_GL={backend}: ", 1)[1].strip()]
    assert "y.mp4: 37 frames, 96x72, 30 fps, H.264, drawn by pybullet" in auto.stdout
    assert len(decoded_any(tmp_path / "y.mp4")) == 37


def decoded_any(path: Path) -> list[bytes]:
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    next(reader)
    return list(reader)


NO_MUJOCO = """
import sys, importlib.abc
class Gone(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "mujoco" or name.startswith("mujoco."):
            raise ImportError("No module named 'mujoco'")
        return None
sys.meta_path.insert(0, Gone())
from robokit.cli import main
code = main(sys.argv[1:])
print("mujoco imported:", "mujoco" in sys.modules)
sys.exit(code)
"""
"""robokit's command line where ``import mujoco`` fails as it does without the optional extra."""


@pytest.mark.slow
def test_without_mujoco_pybullet_draws_every_video(mujoco_run: Path, pybullet_run: Path, tmp_path: Path) -> None:
    script = tmp_path / "no_mujoco.py"
    script.write_text(NO_MUJOCO)

    def video(run: Path, *extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, str(script), "video", str(run), "--size", "96x72", "--workers", "1",
                               *extra], cwd=tmp_path, capture_output=True, text=True, timeout=120)

    plain = video(pybullet_run, "-o", "pb.mp4")
    assert plain.returncode == 0 and plain.stderr == "", plain.stderr
    assert "drawn by pybullet" in plain.stdout and "mujoco imported: False" in plain.stdout
    fallen = video(mujoco_run, "-o", "mj.mp4")
    assert fallen.returncode == 0, fallen.stderr
    assert fallen.stderr.strip() == ("robokit: note: drawn by PyBullet: the run ran on MuJoCo, which cannot render "
                                     "here (mujoco is not installed: pip install 'robokit[mujoco]')")
    assert "drawn by pybullet" in fallen.stdout
    refused = video(mujoco_run, "-o", "no.mp4", "--renderer", "mujoco")
    assert refused.returncode == 2 and "mujoco is not installed" in refused.stderr
    assert len(decoded_any(tmp_path / "pb.mp4")) == len(decoded_any(tmp_path / "mj.mp4")) == 37
