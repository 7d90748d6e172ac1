"""Cost of the run record on the main job, and how fast `robokit video` renders.

1. **Recording overhead**: the whole main job (``configs/sort_robot.toml``: build, run to the end, close) timed
   with the recorder's pose log at 30 Hz (plus the trace file) and without any record, alternating, ``--repeats``
   pairs. Prints each pair and the ratio of the medians (target: <= 1.03). Both runs must end identically.
2. **Video render rate**: frames per second of ``robokit video``'s renderer for the recorded run (rebuild the
   scene, set the poses, render each frame with TinyRenderer and draw the overlay; no encoding), on the same run:
   at ``--size`` serial (one process) and parallel (``--workers``, default one per core: today's default command),
   and the former default command (640x480, one process; the per-frame code is the same), with
   wall time and CPU time (a parallel figure includes its workers' CPU and their start-up). Two labelled ratios:
   serial vs workers at the same size, and the default command before/after (smaller default frame + workers).
   Then, in CPU time, the best speed-up two cores allow at the same size given the serial parts (scene rebuild, a
   helper's start-up).

    python benchmarks/record.py [--repeats 7] [--size 480x360] [--video-frames 0 (= all)] [--workers N]
    python benchmarks/record.py --video-only     # skip the recording overhead part (one run, then the video)

The machine's load (``os.getloadavg``) is printed with the figures: re-measure on an idle machine.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from robokit.config import load_config
from robokit.plugin_api.plugins import load_plugins
from robokit.record.format import RunRecord
from robokit.runner import run_config

CONFIG = Path(__file__).resolve().parent.parent / "configs" / "sort_robot.toml"
OLD_SIZE = (640, 480)
"""``robokit video``'s former default frame size (rendered in one process)."""


def one_run(plugins: Any, record: bool, folder: Path) -> tuple[float, dict]:
    """Wall seconds for one whole main-job run (build + run + close + record files), and its behaviour result."""
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        cfg = load_config(CONFIG, plugins)
        start = time.perf_counter()
        out = run_config(cfg, plugins, record=record, report=False)
        elapsed = time.perf_counter() - start
    finally:
        os.chdir(cwd)
    return elapsed, {k: v for k, v in out.result.to_dict().items() if k not in ("run_id", "wall_time", "started_at")}


def overhead(repeats: int, folder: Path) -> tuple[Path, float]:
    plugins = load_plugins()
    with_rec: list[float] = []
    without: list[float] = []
    reference = None
    for i in range(repeats):
        order = (True, False) if i % 2 == 0 else (False, True)
        for record in order:
            t, result = one_run(plugins, record, folder)
            (with_rec if record else without).append(t)
            reference = reference or result
            assert result == reference, "recording changed the run"
        print(f"  pair {i + 1}: with record {with_rec[-1]:.3f} s, without {without[-1]:.3f} s, "
              f"ratio {with_rec[-1] / without[-1]:.3f}")
    ratio = statistics.median(with_rec) / statistics.median(without)
    print(f"recording overhead (sort_robot, pose log 30 Hz + trace): median with {statistics.median(with_rec):.3f} s"
          f" / without {statistics.median(without):.3f} s = {ratio:.3f}  (target <= 1.03)")
    runs = sorted((folder / "results").iterdir(), key=lambda d: d.stat().st_mtime)
    return runs[-1], statistics.median(without)


def sample_cost(samples: int = 2000) -> float:
    """CPU microseconds per pose sample on the main job's scene (the recorder's whole per-sample work)."""
    from robokit.record.recorder import Recorder
    from robokit.testing import make_sim

    with tempfile.TemporaryDirectory() as tmp, make_sim(CONFIG) as sim:
        rec = Recorder(sim, Path(tmp), pose_hz=30)
        start = time.process_time()  # CPU time: the figure a loaded machine's wall clock would inflate
        for k in range(samples):
            rec.sample(k)
        cost = (time.process_time() - start) / samples * 1e6
        rec.close()
    return cost


def render_rate(run: Path, size: tuple[int, int], limit: int, workers: int) -> None:
    import resource

    from robokit.record.video import frame_bytes

    rec = RunRecord(run)
    if limit:
        keep = limit / 30.0 - 1e-9
        n = int((rec.poses["t"] <= keep).sum())
        for k in list(rec.poses):
            rec.poses[k] = rec.poses[k][:n]
    def cpu() -> float:
        own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime

    rows = []
    for label, at, w in ((f"{size[0]}x{size[1]} serial", size, 1),
                         (f"{size[0]}x{size[1]} {workers} workers", size, workers),
                         (f"{OLD_SIZE[0]}x{OLD_SIZE[1]} serial", OLD_SIZE, 1)):
        start, cpu0 = time.perf_counter(), cpu()
        count = sum(1 for _ in frame_bytes(rec, fps=30.0, size=at, view=None, workers=w))
        rows.append((label, count, time.perf_counter() - start, cpu() - cpu0))
    print(f"video render rate, {rows[0][1]} frames (scene rebuild + pose + render + overlay, no encoding):")
    for label, count, wall, spent in rows:
        print(f"  {label:<20} {count / wall:6.1f} frames/s wall   {wall:6.2f} s wall   {spent:6.2f} s CPU")
    (_, _, serial, _), (_, _, parallel, _), (_, _, old, _) = rows
    print(f"  same size, serial vs {workers} workers ({size[0]}x{size[1]}): {serial / parallel:.2f}x (wall)")
    print(f"  default command before/after (smaller default frame + workers; {OLD_SIZE[0]}x{OLD_SIZE[1]} serial when "
          f"formerly vs {size[0]}x{size[1]} with {workers} workers now): {old / parallel:.2f}x (wall)")
    print(f"  load average now: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


def _helper_start(folder: str) -> None:
    from robokit.record.video import _worker_init

    _worker_init(folder, None, (480, 360), 30.0)


def parallel_bound(run: Path, size: tuple[int, int], limit: int) -> None:
    """What limits the parallel speed-up on 2 cores, in CPU seconds (a loaded machine inflates wall time, not
    these): the scene rebuild R every process does before its first frame, a helper's start-up S (interpreter,
    imports, its own rebuild; spawned, so it starts S after this process), and the render of one frame f.
    This process renders from R on and the helper from S on, so with no other overhead the N frames are done at
    T = (R + S + N f) / 2 against R + N f serially: 2 (R + N f) / (R + S + N f) < 2 since S > R."""
    import multiprocessing
    import resource

    from robokit.record.scene import choose_view, rebuild
    from robokit.record.video import Renderer, frame_indices, overlay

    rec = RunRecord(run)
    frames = limit or len(frame_indices(rec.poses["t"], 30.0))
    start = time.process_time()
    scene = rebuild(rec)
    r = time.process_time() - start
    renderer = Renderer(scene, choose_view(scene, None, size[0] / size[1]), size)
    samples = frame_indices(rec.poses["t"], 30.0)[: max(1, min(frames, 40))]
    spans = rec.spans()
    start = time.process_time()
    for k, i in enumerate(samples):
        scene.set_frame(i)
        overlay(renderer.render(), k / 30, rec.state_at(spans, k / 30)).tobytes()
    f = (time.process_time() - start) / len(samples)
    scene.close()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    helper = multiprocessing.get_context("spawn").Process(target=_helper_start, args=(str(run),))
    helper.start()
    helper.join()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    s = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    bound = 2 * (r + frames * f) / (r + s + frames * f)
    print(f"  CPU: rebuild R = {r:.3f} s, helper start-up S = {s:.3f} s, frame f = {1000 * f:.1f} ms x {frames}: "
          f"best 2-core speed-up 2(R+Nf)/(R+S+Nf) = {bound:.3f}x (a fork after the rebuild, S = R: "
          f"{2 * (r + frames * f) / (2 * r + frames * f):.3f}x)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--size", default="480x360")
    ap.add_argument("--video-frames", type=int, default=0, help="render only the first N frames (0: all)")
    ap.add_argument("--workers", type=int, default=0, help="parallel render processes (0: one per core)")
    ap.add_argument("--video-only", action="store_true", help="one recorded run, then only the video figures")
    args = ap.parse_args()
    from robokit.record.video import default_workers

    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as tmp:
        if args.video_only:
            one_run(load_plugins(), True, Path(tmp))
            run = next((Path(tmp) / "results").iterdir())
        else:
            run, plain = overhead(args.repeats, Path(tmp))
            cost = sample_cost()
            n = len(RunRecord(run).poses["t"])
            print(f"pose sample cost: {cost:.1f} us per sample x {n} samples = {cost * 1e-6 * n:.4f} s = "
                  f"{100 * cost * 1e-6 * n / plain:.2f} % of the median unrecorded run ({plain:.2f} s)")
        w, h = (int(v) for v in args.size.split("x"))
        render_rate(run, (w, h), args.video_frames, args.workers or default_workers())
        parallel_bound(run, (w, h), args.video_frames)
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
