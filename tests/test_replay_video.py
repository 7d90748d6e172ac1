"""``robokit video`` in parallel: worker processes render the same frames as the serial renderer, in order."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import find_run
from robokit.record.scene import choose_view, rebuild
from robokit.record.video import Renderer, frame_bytes, frame_indices, frames

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.3, 0, 0.6]
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


@pytest.fixture
def record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(SCENE)
    assert main(["run", "scene.toml", "--quiet"]) == 0
    return find_run("last").folder


@pytest.mark.slow
def test_two_workers_render_the_serial_frames_byte_for_byte(record: Path) -> None:
    rec = find_run(str(record))
    size = (96, 72)
    serial = [np.ascontiguousarray(f).tobytes() for _, f in frames(rec, fps=30.0, size=size)]
    parallel = list(frame_bytes(rec, fps=30.0, size=size, view=None, workers=2))
    expected = int(np.floor(rec.poses["t"][-1] * 30 + 1e-6)) + 1  # one frame per 1/30 s, both ends
    assert len(serial) == len(parallel) == expected == len(frame_indices(rec.poses["t"], 30.0))
    assert [i for i, (a, b) in enumerate(zip(serial, parallel, strict=True)) if a != b] == []
    assert serial[0] != serial[-1]  # the arm swings and the box falls: the frames are not all the same picture


@pytest.mark.slow
def test_video_command_with_workers_writes_every_frame(record: Path, capsys: pytest.CaptureFixture) -> None:
    import imageio_ffmpeg

    assert main(["video", "last", "-o", "two.mp4", "--size", "96x72", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert "two.mp4: 37 frames, 96x72, 30 fps, H.264" in out  # 1.2 s at 30 Hz, both ends
    reader = imageio_ffmpeg.read_frames("two.mp4")
    meta = next(reader)
    assert meta["size"] == (96, 72) and sum(1 for _ in reader) == 37
    assert main(["video", "last", "--workers", "0"]) == 2
    assert "--workers must be at least 1, got 0" in capsys.readouterr().err


SUNK = """
[world]
max_time = 1.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.table]
shape = "box"
size = [1.2, 0.8, 0.1]
position = [0, 0, -0.05]
mass = 0
rgba = [0.8, 0.5, 0.1, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[behaviour]
type = "record"
components = []
duration = 0.2
"""
"""A table sunk to put its top at z = 0, in the floor's plane, with a 1.3 m arm standing on it."""


def test_the_default_view_shows_every_body_whole_and_a_table_in_the_floor_s_plane(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sunk.toml").write_text(SUNK)
    assert main(["run", "sunk.toml", "--quiet"]) == 0
    rec = find_run("last")
    size = (160, 120)
    _, first = next(frames(rec, fps=30.0, size=size))
    with rebuild(rec) as scene:
        renderer = Renderer(scene, choose_view(scene, None, size[0] / size[1]), size)
        assert scene.lowered["plane"] > 0.05  # drawn under the table's bottom, not in its top's plane
        for name in ("table", "kuka"):  # every corner of each body's box inside the picture: the arm's top too
            lo, hi = scene.world.body_aabb(name)
            for corner in [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]:
                col, row = renderer.project(corner)
                assert 0 <= col < size[0] and 0 <= row < size[1], (name, corner, col, row)
        col, row = (int(v) for v in renderer.project((0.45, 0.3, 0.0)))  # the table's top, off the arm
    r, g, b = (int(v) for v in first[row, col])
    assert r > g > b and r - b > 60, (r, g, b)  # the table's orange, not the floor's blue and white
