"""``robokit video``: render a run's record as an H.264 / yuv420p MP4 that browsers play.

The scene is rebuilt in a DIRECT world (:mod:`robokit.record.scene`), posed frame by frame from the pose log (no
physics), rendered with ``getCameraImage`` (TinyRenderer), labelled with the sim time and each state machine's
current state, and encoded by the ffmpeg that ``imageio-ffmpeg`` ships (OpenCV's PyPI wheels cannot write H.264).

Rendering is CPU-only here, so frames are spread over worker processes (one per core by default): each worker
rebuilds the scene from the record in its own DIRECT client and renders every frame of the chunks it is handed;
the chunks come back in order to the one encoder. A frame depends on its pose sample (and on whether an even or odd
number of draws came before it in its client: see ``CHUNK``), so the frames are the serial renderer's, byte for byte.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robokit.errors import UserError
from robokit.extras import require
from robokit.record.format import RunRecord
from robokit.record.scene import Scene, View, choose_view, rebuild

DEFAULT_SIZE = (480, 360)
"""Default frame size. TinyRenderer costs ~80 ms of CPU per 480x360 frame of the main job (~127 ms at 640x480), so
its 239 frames (8 s at the pose log's 30 Hz) take ~11 s on two cores: ready in well under 20 s with start-up and
encoding; ``--size 640x480`` for a sharper one."""
CHUNK = 8
"""Frames per job handed to a worker: large enough to keep the pipe quiet, small enough to balance two cores. Even:
TinyRenderer re-normalises a mesh's stored normals in place each time it draws it, which can change a pixel's shading
by one level from one draw to the next (period two), so each frame must follow as many draws, mod 2, as in one
process."""


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
        light = {} if self.scene.light_direction is None else {"lightDirection": self.scene.light_direction}
        _, _, rgba, _, _ = self.scene.world.client.getCameraImage(
            w, h, viewMatrix=self.view_matrix, projectionMatrix=self.projection, renderer=p.ER_TINY_RENDERER,
            flags=p.ER_NO_SEGMENTATION_MASK, shadow=0, **light)
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


def frames(rec: RunRecord, *, fps: float | None = None, size: tuple[int, int] = DEFAULT_SIZE,
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


def render_still(rec: RunRecord, out: Path, *, at: float, size: tuple[int, int] = DEFAULT_SIZE,
                 view: str | None = None) -> float:
    """Write one PNG of the scene at sim time ``at`` (the pose sample at or before it), with the overlay.

    Returns the sim time of the sample drawn.
    """
    import cv2

    t = rec.poses["t"]
    i = int(np.clip(np.searchsorted(t, at + 1e-9, side="right") - 1, 0, len(t) - 1))
    with rebuild(rec) as scene:
        renderer = Renderer(scene, choose_view(scene, view, size[0] / size[1]), size)  # poses the scene at sample 0
        scene.set_frame(i)
        now = float(t[i])
        image = overlay(renderer.render(), now, rec.state_at(rec.spans(), now))
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise UserError(f"could not write {out} (give a .png file name)")
    return now


# ----------------------------------------------------------------- parallel rendering
_WORKER: dict[str, object] = {}
"""The scene a worker process rebuilt once, with its renderer (one per process; never pickled)."""


def _worker_init(folder: str, view: str | None, size: tuple[int, int], rate: float) -> None:
    rec = RunRecord(Path(folder))
    scene = rebuild(rec)
    _WORKER.update(rec=rec, scene=scene, spans=rec.spans(), rate=rate,
                   renderer=Renderer(scene, choose_view(scene, view, size[0] / size[1]), size))


def _worker_render(job: list[tuple[int, int]]) -> list[bytes]:
    """Render the frames ``(video frame k, pose sample i)`` of one chunk; RGB bytes, in order."""
    rec, scene, renderer = _WORKER["rec"], _WORKER["scene"], _WORKER["renderer"]
    assert isinstance(rec, RunRecord) and isinstance(scene, Scene) and isinstance(renderer, Renderer)
    rate, spans = float(_WORKER["rate"]), _WORKER["spans"]  # type: ignore[arg-type]
    out = []
    for k, i in job:
        scene.set_frame(i)
        now = k / rate
        out.append(overlay(renderer.render(), now, rec.state_at(spans, now)).tobytes())  # type: ignore[arg-type]
    return out


def default_workers() -> int:
    """One worker per core this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def frame_bytes(rec: RunRecord, *, fps: float, size: tuple[int, int], view: str | None,
                workers: int) -> Iterator[bytes]:
    """Every video frame of a record as RGB bytes, in order; ``workers`` > 1 renders them in that many processes.

    Workers are started with ``spawn`` (a pybullet client must never cross a process boundary) and each rebuilds
    the scene once. Errors in a worker (a URDF missing here) come back as the same exception.
    """
    jobs = list(enumerate(frame_indices(rec.poses["t"], fps)))
    if workers <= 1 or len(jobs) < 2 * CHUNK:
        for _, frame in frames(rec, fps=fps, size=size, view=view):
            yield np.ascontiguousarray(frame).tobytes()
        return
    import multiprocessing

    chunks = [jobs[a:a + CHUNK] for a in range(0, len(jobs), CHUNK)]
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(min(workers, len(chunks)), _worker_init, (str(rec.folder), view, size, fps)) as pool:
        for chunk in pool.imap(_worker_render, chunks):
            yield from chunk


def render_video(rec: RunRecord, out: Path, *, fps: float | None = None, size: tuple[int, int] = DEFAULT_SIZE,
                 view: str | None = None, workers: int | None = None, progress: bool | None = False) -> VideoStats:
    """Write the record's video to ``out`` (H.264, yuv420p, ``+faststart`` so browsers start playing at once).

    ``workers``: render processes (default one per core; 1 renders in this process). ``progress``: a tqdm bar on
    stderr (``None``: only when stderr is a terminal).

    Raises:
        UserError: imageio-ffmpeg is not installed, the record has no pose log, or a bad ``fps``/``view``.
    """
    require("video", "robokit video", ("imageio_ffmpeg",))
    import imageio_ffmpeg
    from tqdm import tqdm

    rate = fps or float(rec.header.get("pose_hz") or 30.0)
    if rate <= 0:
        raise UserError(f"--fps must be positive, got {rate:g}")
    total = len(frame_indices(rec.poses["t"], rate))
    if total and view is not None:  # a bad --view is one line here, not a traceback from a worker
        with rebuild(rec) as scene:
            choose_view(scene, view, size[0] / size[1])
    out.parent.mkdir(parents=True, exist_ok=True)
    w, h = size
    writer = imageio_ffmpeg.write_frames(
        str(out), (w, h), fps=rate, codec="libx264", pix_fmt_in="rgb24", pix_fmt_out="yuv420p", macro_block_size=1,
        quality=None, bitrate=None, ffmpeg_log_level="error",
        output_params=["-crf", "23", "-preset", "veryfast", "-movflags", "+faststart"])
    writer.send(None)
    count = 0
    start = time.perf_counter()  # measures the render rate only; no logic depends on it
    bar = tqdm(total=total, unit="frame", desc="video", disable=None if progress is None else not progress,
               leave=False)
    try:
        for data in frame_bytes(rec, fps=rate, size=size, view=view, workers=workers or default_workers()):
            writer.send(data)
            count += 1
            bar.update()
    finally:
        bar.close()
        writer.close()
    busy = time.perf_counter() - start
    stats = VideoStats(count, w, h, rate, count / busy if busy > 0 else 0.0)
    note = {"path": str(out.resolve()), "frames": count, "width": w, "height": h, "fps": rate}
    try:  # lets `robokit view` embed this video instead of rendering another one
        (rec.folder / "video.json").write_text(json.dumps(note), encoding="utf-8")
    except OSError:
        pass
    return stats
