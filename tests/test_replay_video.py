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


def test_two_workers_render_the_serial_frames_byte_for_byte(record: Path) -> None:
    rec = find_run(str(record))
    size = (96, 72)
    serial = [np.ascontiguousarray(f).tobytes() for _, f in frames(rec, fps=30.0, size=size)]
    parallel = list(frame_bytes(rec, fps=30.0, size=size, view=None, workers=2))
    expected = int(np.floor(rec.poses["t"][-1] * 30 + 1e-6)) + 1  # one frame per 1/30 s, both ends
    assert len(serial) == len(parallel) == expected == len(frame_indices(rec.poses["t"], 30.0))
    assert [i for i, (a, b) in enumerate(zip(serial, parallel, strict=True)) if a != b] == []
    assert serial[0] != serial[-1]  # the arm swings and the box falls: the frames are not all the same picture


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


def test_layered_frames_are_the_whole_scene_frames_byte_for_byte(record: Path) -> None:
    """The still plane drawn once under the moving arm and box gives the pixels of drawing every body each frame."""
    rec = find_run(str(record))
    for view in (None, "top"):
        whole = [f for _, f in frames(rec, fps=30.0, size=(160, 120), view=view, layered=False)]
        layered = [f for _, f in frames(rec, fps=30.0, size=(160, 120), view=view)]
        assert len(whole) == len(layered) == 37
        assert [k for k, (a, b) in enumerate(zip(whole, layered, strict=True)) if not np.array_equal(a, b)] == []
    with rebuild(rec) as scene:
        renderer = Renderer(scene, choose_view(scene, None, 4 / 3), (160, 120))
        assert renderer.still == ["plane"] and renderer.moving == ["box", "kuka"]


TIE = """
[world]
max_time = 1.0

[bodies.slab]
shape = "box"
size = [0.3, 0.3, 0.3]
position = [0, 0, 0.15]
mass = 0
rgba = [0.1, 0.8, 0.1, 1]

[bodies.cube]
shape = "box"
size = [0.3, 0.3, 0.3]
position = [0, 0, 0.6]
rgba = [0.9, 0.1, 0.1, 1]

[behaviour]
type = "record"
components = []
duration = 0.5
"""


def test_layers_equally_near_show_the_body_the_whole_scene_shows(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """A moving cube put exactly where a still slab of another colour is: every pixel of the two ties in depth, and
    the layered frame still shows what drawing both bodies together shows."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tie.toml").write_text(TIE)
    assert main(["run", "tie.toml", "--quiet"]) == 0
    rec = find_run("last")
    cube, slab = rec.poses["base/cube"], rec.poses["base/slab"]
    cube[::2] = slab[::2]  # every other sample: the cube inside the slab, face on face; between, falling above it
    whole = [f for _, f in frames(rec, fps=30.0, size=(64, 48), layered=False)]
    layered = [f for _, f in frames(rec, fps=30.0, size=(64, 48))]
    assert [k for k, (a, b) in enumerate(zip(whole, layered, strict=True)) if not np.array_equal(a, b)] == []
    with rebuild(rec) as scene:
        renderer = Renderer(scene, choose_view(scene, None, 4 / 3), (64, 48))
        assert renderer.still == ["slab"]
        for i in range(0, len(rec.poses["t"]), 2):
            renderer.frame(i)
        assert renderer.ties == len(range(0, len(rec.poses["t"]), 2))
