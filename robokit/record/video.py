"""``robokit video``: render a run's record as an H.264 / yuv420p MP4 that browsers play.

The scene is rebuilt in a DIRECT world (:mod:`robokit.record.scene`), posed frame by frame from the pose log (no
physics), rendered with ``getCameraImage`` (TinyRenderer), labelled with the sim time and each state machine's
current state, and encoded by the ffmpeg that ``imageio-ffmpeg`` ships (OpenCV's PyPI wheels cannot write H.264).
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robokit.errors import UserError
from robokit.record.format import RunRecord
from robokit.record.scene import Scene, View, choose_view, rebuild


@dataclass
class VideoStats:
    """What was written: frame count, size, frames per (sim) second, and how fast frames were rendered."""

    frames: int
    width: int
    height: int
    fps: float
    render_fps: float


def frame_indices(t: np.ndarray, fps: float) -> list[int]:
    """For each video frame ``k`` at sim time ``k / fps``, the pose-log sample at or just before it."""
    if len(t) == 0:
        return []
    n = int(np.floor(t[-1] * fps + 1e-6)) + 1
    times = np.arange(n) / fps
    return np.clip(np.searchsorted(t, times + 1e-9, side="right") - 1, 0, len(t) - 1).tolist()  # type: ignore[no-any-return]


class Renderer:
    """Renders one posed scene through one camera at one size (TinyRenderer: no display or GPU needed)."""

    def __init__(self, scene: Scene, view: View, size: tuple[int, int]) -> None:
        self.scene, self.view, self.size = scene, view, size
        client = scene.world.client
        w, h = size
        self.view_matrix = client.computeViewMatrix(list(view.eye), list(view.target), list(view.up))
        self.projection = client.computeProjectionMatrixFOV(fov=view.fov, aspect=w / h, nearVal=0.02, farVal=50.0)

    def render(self) -> np.ndarray:
        """The current scene as an RGB array (height, width, 3), uint8."""
        import pybullet as p

        w, h = self.size
        _, _, rgba, _, _ = self.scene.world.client.getCameraImage(
            w, h, viewMatrix=self.view_matrix, projectionMatrix=self.projection, renderer=p.ER_TINY_RENDERER,
            flags=p.ER_NO_SEGMENTATION_MASK, shadow=0)
        return np.asarray(rgba, dtype=np.uint8).reshape(h, w, 4)[:, :, :3].copy()

    def project(self, point: tuple[float, float, float]) -> tuple[float, float]:
        """Pixel (column, row) where a world point appears in this renderer's frames."""
        v = np.asarray(self.view_matrix, float).reshape(4, 4).T
        pr = np.asarray(self.projection, float).reshape(4, 4).T
        clip = pr @ v @ np.array([*point, 1.0])
        ndc = clip[:3] / clip[3]
        w, h = self.size
        return (ndc[0] + 1) / 2 * w, (1 - ndc[1]) / 2 * h


def overlay(frame: np.ndarray, t: float, states: dict[str, str]) -> np.ndarray:
    """Draw the sim time and each machine's state in the top-left corner (OpenCV text on a dark band)."""
    import cv2

    lines = [f"t = {t:6.2f} s"] + [f"{name}: {state}" for name, state in states.items()]
    scale = max(0.4, frame.shape[0] / 900)
    step = int(26 * scale / 0.6)
    width = max(cv2.getTextSize(line, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0] for line in lines) + 16
    band = frame[: step * len(lines) + 10, :width]
    band[:] = (band * 0.45).astype(np.uint8)
    for i, line in enumerate(lines):
        cv2.putText(frame, line, (8, step * (i + 1)), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1,
                    cv2.LINE_AA)
    return frame


def frames(rec: RunRecord, *, fps: float | None = None, size: tuple[int, int] = (640, 480),
           view: str | None = None, scene: Scene | None = None) -> Iterator[tuple[float, np.ndarray]]:
    """Yield ``(sim time, RGB frame with overlay)`` for every video frame of a record."""
    own = scene is None
    scene = scene or rebuild(rec)
    try:
        t = rec.poses["t"]
        rate = fps or float(rec.header.get("pose_hz") or 30.0)
        renderer = Renderer(scene, choose_view(scene, view, size[0] / size[1]), size)
        spans = rec.spans()
        for k, i in enumerate(frame_indices(t, rate)):
            scene.set_frame(i)
            now = k / rate
            yield now, overlay(renderer.render(), now, rec.state_at(spans, now))
    finally:
        if own:
            scene.close()


def render_still(rec: RunRecord, out: Path, *, at: float, size: tuple[int, int] = (640, 480),
                 view: str | None = None) -> float:
    """Write one PNG of the scene at sim time ``at`` (the pose sample at or before it), with the overlay.

    Returns the sim time of the sample drawn.
    """
    import cv2

    t = rec.poses["t"]
    i = int(np.clip(np.searchsorted(t, at + 1e-9, side="right") - 1, 0, len(t) - 1))
    with rebuild(rec) as scene:
        scene.set_frame(i)
        renderer = Renderer(scene, choose_view(scene, view, size[0] / size[1]), size)
        now = float(t[i])
        image = overlay(renderer.render(), now, rec.state_at(rec.spans(), now))
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise UserError(f"could not write {out} (give a .png file name)")
    return now


def render_video(rec: RunRecord, out: Path, *, fps: float | None = None, size: tuple[int, int] = (640, 480),
                 view: str | None = None) -> VideoStats:
    """Write the record's video to ``out`` (H.264, yuv420p, ``+faststart`` so browsers start playing at once).

    Raises:
        UserError: imageio-ffmpeg is not installed, or the record has no pose log.
    """
    try:
        import imageio_ffmpeg
    except ImportError:
        raise UserError("robokit video needs imageio-ffmpeg: pip install 'robokit[video]'") from None
    rate = fps or float(rec.header.get("pose_hz") or 30.0)
    if rate <= 0:
        raise UserError(f"--fps must be positive, got {rate:g}")
    out.parent.mkdir(parents=True, exist_ok=True)
    w, h = size
    writer = imageio_ffmpeg.write_frames(
        str(out), (w, h), fps=rate, codec="libx264", pix_fmt_in="rgb24", pix_fmt_out="yuv420p", macro_block_size=1,
        quality=None, bitrate=None, ffmpeg_log_level="error",
        output_params=["-crf", "23", "-preset", "veryfast", "-movflags", "+faststart"])
    writer.send(None)
    count, busy = 0, 0.0
    try:
        gen = frames(rec, fps=rate, size=size, view=view)
        while True:
            start = time.perf_counter()  # measures the render rate only; no logic depends on it
            item = next(gen, None)
            busy += time.perf_counter() - start
            if item is None:
                break
            writer.send(np.ascontiguousarray(item[1]).tobytes())
            count += 1
    finally:
        writer.close()
    stats = VideoStats(count, w, h, rate, count / busy if busy > 0 else 0.0)
    note = {"path": str(out.resolve()), "frames": count, "width": w, "height": h, "fps": rate}
    try:  # lets `robokit view` embed this video instead of rendering another one
        (rec.folder / "video.json").write_text(json.dumps(note), encoding="utf-8")
    except OSError:
        pass
    return stats
