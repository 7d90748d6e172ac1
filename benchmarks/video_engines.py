"""Render time per video frame: MuJoCo (``mujoco.Renderer`` through EGL, Mesa) against PyBullet's TinyRenderer, on
the same record, interleaved in one process.

The main job (``configs/sort_robot.toml``) is run once on MuJoCo with its pose log; its scene is rebuilt twice from
the record, in MuJoCo and in PyBullet, with ``robokit video``'s renderers at the same size and default view. For every
video frame both scenes are posed from the same pose sample and each renderer draws one frame (the engine's drawing
only: the overlay and encoding are the same for both), the order alternating frame by frame. Per frame: wall time
and this process's CPU time (which counts Mesa's llvmpipe threads: MuJoCo's frames are drawn on the CPU here too,
on as many threads as cores; ``LP_NUM_THREADS=1`` for one), medians over the frames, and the ratios.

    python benchmarks/video_engines.py [--config configs/sort_robot.toml] [--size 480x360] [--frames 0 (= all)]

The machine's load is printed with the figures.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "configs" / "sort_robot.toml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--config", default=str(CONFIG))
    ap.add_argument("--size", default="480x360")
    ap.add_argument("--frames", type=int, default=0, help="time only the first N video frames (0: all)")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.lower().split("x"))
    size = (w, h)

    from robokit.record.format import find_run
    from robokit.record.scene import choose_view, rebuild
    from robokit.record.video import frame_indices, make_renderer

    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "robokit.cli", "run", str(Path(args.config).resolve()), "--engine",
                        "mujoco", "--quiet"], cwd=tmp, check=True)
        rec = find_run("last", str(Path(tmp) / "results"))
        samples = frame_indices(rec.poses["t"], 30.0)
        if args.frames:
            samples = samples[: args.frames]
        scenes = {engine: rebuild(rec, engine) for engine in ("mujoco", "pybullet")}
        renderers = {engine: make_renderer(scene, choose_view(scene, None, w / h), size)
                     for engine, scene in scenes.items()}
        wall: dict[str, list[float]] = {e: [] for e in scenes}
        cpu: dict[str, list[float]] = {e: [] for e in scenes}
        for engine, renderer in renderers.items():  # a first frame each, not counted (a context, a warm cache)
            scenes[engine].set_frame(samples[0])
            renderer.render()
        for k, i in enumerate(samples):
            order = ("mujoco", "pybullet") if k % 2 == 0 else ("pybullet", "mujoco")
            for engine in order:
                scenes[engine].set_frame(i)
                w0, c0 = time.perf_counter(), time.process_time()
                renderers[engine].render()
                wall[engine].append(time.perf_counter() - w0)
                cpu[engine].append(time.process_time() - c0)
        for renderer in renderers.values():
            renderer.close()
        for scene in scenes.values():
            scene.close()

    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    print(f"command: python benchmarks/video_engines.py --size {args.size}"
          + (f" --frames {args.frames}" if args.frames else "") + f"   (load {load}, {os.cpu_count()} cores)")
    print(f"record: {Path(args.config).name} on MuJoCo, {len(samples)} video frames at {w}x{h}")
    med = {e: (statistics.median(wall[e]), statistics.median(cpu[e])) for e in scenes}
    for engine, label in (("mujoco", "MuJoCo (mujoco.Renderer, EGL)"), ("pybullet", "PyBullet (TinyRenderer)")):
        print(f"  {label:32s} per frame: wall {1000 * med[engine][0]:7.2f} ms   CPU {1000 * med[engine][1]:7.2f} ms")
    print(f"  PyBullet / MuJoCo per frame: wall {med['pybullet'][0] / med['mujoco'][0]:.1f}x   "
          f"CPU {med['pybullet'][1] / med['mujoco'][1]:.1f}x")


if __name__ == "__main__":
    main()
