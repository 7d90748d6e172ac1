"""``robokit video``: render a run's record as an H.264 / yuv420p MP4 that browsers play.

The scene is rebuilt in a DIRECT world (:mod:`robokit.record.scene`), posed frame by frame from the pose log (no
physics), rendered, labelled with the sim time and each state machine's current state, and encoded by the ffmpeg
that ``imageio-ffmpeg`` ships (OpenCV's PyPI wheels cannot write H.264). The engine that ran draws it
(:func:`choose_renderer`): PyBullet's ``getCameraImage`` (TinyRenderer), or for a MuJoCo run the run's MuJoCo model
with ``mujoco.Renderer`` through EGL (:mod:`robokit.engines.mujoco.replay_render`).

Rendering is CPU-only here, so frames are spread over worker processes (one per core by default): each worker
rebuilds the scene from the record in its own DIRECT client and renders every frame of the chunks it is handed;
the chunks come back in order to the one encoder. A frame depends on its pose sample (and on whether an even or odd
number of draws came before it in its client: see ``CHUNK``), so the frames are the serial renderer's, byte for byte.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import tempfile
import time
from collections.abc import Generator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import UserError
from robokit.extras import require
from robokit.record.atomic import OutputFailed, atomic_output
from robokit.record.format import RunRecord
from robokit.record.layout import VIDEO_NOTE
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
RENDERERS = ("auto", "pybullet", "mujoco")
"""``--renderer`` choices: ``auto`` is the engine that ran the run (PyBullet when MuJoCo cannot draw here, with a
note saying why), a name is that engine or one line saying why it cannot."""


@dataclass
class VideoStats:
    """What was written: frame count, size, frames per (sim) second, and how fast frames were rendered."""

    frames: int
    width: int
    height: int
    fps: float
    render_fps: float
    renderer: str = "pybullet"
    """The engine that drew the frames."""
    note: str | None = None
    """Why ``auto`` drew with another engine than the one that ran, or None."""


def record_engine(rec: RunRecord) -> str:
    """The engine that ran the record's run (its config's ``world.engine``; PyBullet when none is named)."""
    world = rec.header.get("config", {}).get("world", {})
    return str(world.get("engine") or "pybullet") if isinstance(world, dict) else "pybullet"


def mujoco_problem() -> str | None:
    """Why MuJoCo cannot draw frames here (not installed, no OpenGL context), or None: it can. The warnings an
    OpenGL backend prints while it fails (GLFW without a display) are left out: the answer says it in one line."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            from robokit.engines.mujoco import replay_render
        except ImportError:
            return "mujoco is not installed: pip install 'robokit[mujoco]'"
        except Exception as exc:  # noqa: BLE001 - MuJoCo's import fails on a MUJOCO_GL it cannot load
            why = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        else:
            why = replay_render.problem()  # type: ignore[assignment]
            if why is None:
                return None
    return f"MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}: {why}"


def choose_renderer(rec: RunRecord, choice: str = "auto") -> tuple[str, str | None]:
    """The engine that draws the record's frames for ``--renderer choice``, and a note when ``auto`` fell back.

    ``auto`` is the engine that ran; when that is MuJoCo and MuJoCo cannot draw here, PyBullet draws (the video is
    still made: a run page, ``robokit run --video``) and the note says why. ``mujoco`` asked for by name and
    unable to draw is an error.

    Raises:
        UserError: an unknown choice, or ``mujoco`` asked for where it cannot draw (one line saying why).
    """
    if choice not in RENDERERS:
        raise UserError(f"--renderer: unknown renderer {choice!r}; choose one of {', '.join(RENDERERS)}")
    wanted = record_engine(rec) if choice == "auto" else choice
    if wanted != "mujoco":
        return "pybullet", None
    why = mujoco_problem()
    if why is None:
        return "mujoco", None
    if choice == "auto":
        return "pybullet", f"drawn by PyBullet: the run ran on MuJoCo, which cannot render here ({why})"
    raise UserError(f"--renderer mujoco: MuJoCo cannot render here ({why}); use --renderer pybullet")


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
        return project(self.view_matrix, self.projection, self.size, point)

    def close(self) -> None:
        """Nothing to release (the scene's client draws)."""


def project(view_matrix: Any, projection: Any, size: tuple[int, int],
            point: tuple[float, float, float]) -> tuple[float, float]:
    """Pixel (column, row) where a world point appears through OpenGL ``view_matrix`` and ``projection``."""
    v = np.asarray(view_matrix, float).reshape(4, 4).T
    pr = np.asarray(projection, float).reshape(4, 4).T
    clip = pr @ v @ np.array([*point, 1.0])
    ndc = clip[:3] / clip[3]
    w, h = size
    return (ndc[0] + 1) / 2 * w, (1 - ndc[1]) / 2 * h


class MujocoRenderer:
    """Renders one posed scene rebuilt in MuJoCo through one camera at one size (``mujoco.Renderer``, EGL)."""

    def __init__(self, scene: Scene, view: View, size: tuple[int, int]) -> None:
        from robokit.engines.mujoco.replay_render import FAR, NEAR, SceneRenderer

        self.scene, self.view, self.size = scene, view, size
        world = scene.world
        w, h = size
        self.view_matrix = world.view_matrix(view.eye, view.target, view.up)
        self.projection = world.projection_matrix(view.fov, w / h, NEAR, FAR)
        self.drawer = SceneRenderer(world, self.view_matrix, self.projection, size)

    def render(self) -> np.ndarray:
        """The current scene as an RGB array (height, width, 3), uint8."""
        return self.drawer.render()

    def project(self, point: tuple[float, float, float]) -> tuple[float, float]:
        """Pixel (column, row) where a world point appears in this renderer's frames."""
        return project(self.view_matrix, self.projection, self.size, point)

    def close(self) -> None:
        self.drawer.close()


def make_renderer(scene: Scene, view: View, size: tuple[int, int]) -> Renderer | MujocoRenderer:
    """The renderer of the engine the scene was rebuilt in."""
    if scene.world.engine == "mujoco":
        return MujocoRenderer(scene, view, size)
    return Renderer(scene, view, size)


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
           view: str | None = None, scene: Scene | None = None,
           engine: str = "pybullet") -> Iterator[tuple[float, np.ndarray]]:
    """Yield ``(sim time, RGB frame with overlay)`` for every video frame of a record, drawn by ``engine`` (the
    engine ``scene`` was rebuilt in, when one is given)."""
    own = scene is None
    scene = scene or rebuild(rec, engine)
    renderer = None
    try:
        t = rec.poses["t"]
        rate = fps or float(rec.header.get("pose_hz") or 30.0)
        renderer = make_renderer(scene, choose_view(scene, view, size[0] / size[1]), size)
        spans = rec.spans()
        for k, i in enumerate(frame_indices(t, rate)):
            scene.set_frame(i)
            now = k / rate
            yield now, overlay(renderer.render(), now, rec.state_at(spans, now))
    finally:
        if renderer is not None:
            renderer.close()
        if own:
            scene.close()


def render_still(rec: RunRecord, out: Path, *, at: float, size: tuple[int, int] = DEFAULT_SIZE,
                 view: str | None = None, engine: str = "pybullet") -> float:
    """Write one PNG of the scene at sim time ``at`` (the pose sample at or before it), with the overlay, drawn by
    ``engine`` (:func:`choose_renderer`).

    Returns the sim time of the sample drawn.
    """
    import cv2

    t = rec.poses["t"]
    i = int(np.clip(np.searchsorted(t, at + 1e-9, side="right") - 1, 0, len(t) - 1))
    with rebuild(rec, engine) as scene:
        renderer = make_renderer(scene, choose_view(scene, view, size[0] / size[1]), size)  # poses it at sample 0
        try:
            scene.set_frame(i)
            now = float(t[i])
            image = overlay(renderer.render(), now, rec.state_at(rec.spans(), now))
        finally:
            renderer.close()
    ok, png = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    if not ok or out.suffix.lower() != ".png":
        raise UserError(f"could not write {out} (give a .png file name)")
    from robokit.record.atomic import write_bytes

    write_bytes(out, png.tobytes())
    return now


# ----------------------------------------------------------------- parallel rendering
_WORKER: dict[str, object] = {}
"""The scene a worker process rebuilt once, with its renderer (one per process; never pickled)."""


def _worker_init(folder: str, view: str | None, size: tuple[int, int], rate: float, engine: str) -> None:
    """A render worker's start: it ignores Ctrl-C (the parent stops the pool), writes nothing to the terminal (its
    errors come back to the parent as exceptions), and rebuilds the scene when its first job comes (an exception
    in a pool's initializer would only restart the worker)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    devnull = os.open(os.devnull, os.O_WRONLY)
    for fd in (1, 2):
        os.dup2(devnull, fd)
    os.close(devnull)
    _WORKER.update(args=(folder, view, size, rate, engine))


def _worker_scene() -> None:
    if "scene" in _WORKER:
        return
    args: tuple[str, str | None, tuple[int, int], float, str] = _WORKER["args"]  # type: ignore[assignment]
    folder, view, size, rate, engine = args
    rec = RunRecord(Path(folder))
    scene = rebuild(rec, engine)
    _WORKER.update(rec=rec, scene=scene, spans=rec.spans(), rate=rate,
                   renderer=make_renderer(scene, choose_view(scene, view, size[0] / size[1]), size))


def _worker_render(job: list[tuple[int, int]]) -> list[bytes]:
    """Render the frames ``(video frame k, pose sample i)`` of one chunk; RGB bytes, in order."""
    _worker_scene()
    rec, scene, renderer = _WORKER["rec"], _WORKER["scene"], _WORKER["renderer"]
    assert isinstance(rec, RunRecord) and isinstance(scene, Scene)
    assert isinstance(renderer, (Renderer, MujocoRenderer))
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
                workers: int, engine: str = "pybullet") -> Generator[bytes, None, None]:
    """Every video frame of a record as RGB bytes, in order, drawn by ``engine``; ``workers`` > 1 renders them in
    that many processes.

    Workers are started with ``spawn`` (a pybullet client or an OpenGL context must never cross a process boundary)
    and each rebuilds the scene, and makes its renderer, once. Errors in a worker (a URDF missing here, no OpenGL
    context) come back as the same exception.
    """
    jobs = list(enumerate(frame_indices(rec.poses["t"], fps)))
    if workers <= 1 or len(jobs) < 2 * CHUNK:
        for _, frame in frames(rec, fps=fps, size=size, view=view, engine=engine):
            yield np.ascontiguousarray(frame).tobytes()
        return
    import multiprocessing

    chunks = [jobs[a:a + CHUNK] for a in range(0, len(jobs), CHUNK)]
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(min(workers, len(chunks)), _worker_init, (str(rec.folder), view, size, fps, engine)) as pool:
        for chunk in pool.imap(_worker_render, chunks):
            yield from chunk


def render_video(rec: RunRecord, out: Path, *, fps: float | None = None, size: tuple[int, int] = DEFAULT_SIZE,
                 view: str | None = None, workers: int | None = None, progress: bool | None = False,
                 renderer: str = "auto") -> VideoStats:
    """Write the record's video to ``out`` (H.264, yuv420p, ``+faststart`` so browsers start playing at once),
    drawn by the engine :func:`choose_renderer` picks for ``renderer``.

    The video is encoded under a temporary name beside ``out`` (:mod:`robokit.record.atomic`), checked (ffmpeg's
    exit status, and the frame count read back from the file) and only then renamed onto ``out``; its digest goes
    into the run folder's ``video.json``, so ``robokit view`` embeds it only while it is this run's video.
    ``workers``: render processes (default one per core; 1 renders in this process). ``progress``: a tqdm bar on
    stderr (``None``: only when stderr is a terminal).

    Raises:
        UserError: imageio-ffmpeg is not installed, the record has no pose log, a bad ``fps``/``view``, or
            ``renderer="mujoco"`` where MuJoCo cannot draw.
        OutputFailed: ffmpeg could not finish the file (a full disk, a file-size limit): nothing is left at ``out``
            but what was there before.
        KeyboardInterrupt: an interrupt; the partial file is removed first.
    """
    require("video", "robokit video", ("imageio_ffmpeg",))
    from tqdm import tqdm

    rate = fps or float(rec.header.get("pose_hz") or 30.0)
    if rate <= 0:
        raise UserError(f"--fps must be positive, got {rate:g}")
    engine, note = choose_renderer(rec, renderer)
    total = len(frame_indices(rec.poses["t"], rate))
    if total and view is not None:  # a bad --view is one line here, not a traceback from a worker
        with rebuild(rec, engine) as scene:
            choose_view(scene, view, size[0] / size[1])
    w, h = size
    start = time.perf_counter()  # measures the render rate only; no logic depends on it
    bar = tqdm(total=total, unit="frame", desc="video", disable=None if progress is None else not progress,
               leave=False)
    rendered = frame_bytes(rec, fps=rate, size=size, view=view, workers=workers or default_workers(),
                           engine=engine)
    try:
        with atomic_output(out) as tmp:
            count = _encode(rendered, tmp, out, size, rate, bar.update)
            _check_frames(tmp, out, count)
    finally:
        rendered.close()  # stops the render workers at once (an interrupt, ffmpeg gone)
        bar.close()
    busy = time.perf_counter() - start
    stats = VideoStats(count, w, h, rate, count / busy if busy > 0 else 0.0, engine, note)
    write_video_note(rec, out, stats)
    return stats


def write_video_note(rec: RunRecord, out: Path, stats: VideoStats) -> None:
    """Note the video just made in ``<run folder>/video.json``: the file's name (relative to the run folder when
    inside it), its sha256 digest and its size in frames; a note that cannot be written is only a lost shortcut."""
    from robokit.record.atomic import file_digest, write_text

    try:
        where = out.resolve()
        name = where.relative_to(rec.folder.resolve()).as_posix() if where.is_relative_to(rec.folder.resolve()) \
            else str(where)
        note = {"path": name, "sha256": file_digest(out), "bytes": out.stat().st_size, "frames": stats.frames,
                "width": stats.width, "height": stats.height, "fps": stats.fps, "renderer": stats.renderer}
        write_text(rec.folder / VIDEO_NOTE, json.dumps(note))
    except (OSError, OutputFailed):
        pass


def _ffmpeg_command(path: Path, size: tuple[int, int], rate: float) -> list[str]:
    import imageio_ffmpeg

    w, h = size
    return [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", "-loglevel", "error", "-y",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}", "-r", f"{rate:g}", "-i", "pipe:0", "-an",
            "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "23", "-preset", "veryfast",
            "-movflags", "+faststart", "-f", "mp4", str(path)]


def _encode(data: Iterator[bytes], tmp: Path, out: Path, size: tuple[int, int], rate: float,
            tick: Any) -> int:
    """Feed every frame to ffmpeg writing ``tmp``; the frame count. ffmpeg runs in its own session (a Ctrl-C at the
    terminal reaches robokit only, which stops it) and its messages are kept, not printed: a failure is
    :class:`OutputFailed` naming ``out`` with ffmpeg's last line."""
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(_ffmpeg_command(tmp, size, rate), stdin=subprocess.PIPE,
                                stdout=subprocess.DEVNULL, stderr=log, start_new_session=True)
        assert proc.stdin is not None
        count, broken = 0, False
        try:
            for frame in data:
                try:
                    proc.stdin.write(frame)
                except (BrokenPipeError, OSError):
                    broken = True  # ffmpeg stopped (a full disk, a file-size limit): its exit status says why
                    break
                count += 1
                tick()
            with contextlib.suppress(OSError):
                proc.stdin.close()
            code = proc.wait()
        except BaseException:
            proc.kill()
            proc.wait()
            raise
        if code != 0 or broken:
            log.seek(0)
            lines = [ln.strip() for ln in log.read().decode("utf-8", "replace").splitlines() if ln.strip()]
            why = lines[-1] if lines else _status(code)
            raise OutputFailed(out, f"ffmpeg could not finish the video after {count} frame(s): {why}")
    return count


def _status(code: int) -> str:
    """ffmpeg's exit status in words (a negative one is the signal that ended it, e.g. a file-size limit)."""
    import signal

    if code < 0:
        with contextlib.suppress(ValueError):
            return f"ffmpeg was stopped by {signal.Signals(-code).name} ({signal.strsignal(-code)})"
    return f"ffmpeg exited with status {code}"


def _check_frames(tmp: Path, out: Path, expected: int) -> None:
    """Read the frame count back from the finished file; a mismatch is :class:`OutputFailed`."""
    import imageio_ffmpeg

    try:
        found, _ = imageio_ffmpeg.count_frames_and_secs(str(tmp))
    except (RuntimeError, OSError) as exc:
        raise OutputFailed(out, f"the video written cannot be read back: {str(exc).splitlines()[0]}") from None
    if found != expected:
        raise OutputFailed(out, f"the video written holds {found} frame(s), {expected} were sent")
