"""Start-up cost of the ``robokit`` command: process time (user + system CPU) and wall time of whole processes.

Measured, each as the median of ``--repeats`` fresh processes, interleaved:

- ``python -c pass``: the interpreter alone (the floor);
- ``robokit --help``: must import neither pybullet nor OpenCV (checked: the run prints the heavy modules it saw);
- ``robokit run TRIVIAL --quiet``: a plane and a falling box for 0.1 sim seconds, local report on (target:
  under 200 ms of process time);
- ``robokit run configs/patrol_robot.toml --max-time 0.05 --quiet``: a real config's start-up (no camera: OpenCV
  stays unimported);
- ``robokit plugins``: lists every type, so it imports every plugin module.

Then, in this process, where the time of a trivial run goes: imports, plugin discovery (lazy and eager), config,
world, run.

    python benchmarks/startup.py [--repeats 10]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TRIVIAL = """[world]
max_time = 0.1

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0, 0, 0.5]
"""
HEAVY = ("pybullet", "cv2", "numpy", "pydantic", "transitions", "requests")
PROBE = """
import sys
from robokit.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
heavy = [m for m in {heavy!r} if m in sys.modules]
print("heavy modules imported:", ", ".join(heavy) or "none", file=sys.stderr)
"""


def measure(cmd: list[str], cwd: str) -> tuple[float, float]:
    """(process seconds, wall seconds) of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


def in_process(config: Path) -> None:
    """Where a trivial run's time goes, in one fresh child process (so imports are not already cached)."""
    code = f"""
import time, os
t0 = time.perf_counter(); c0 = time.process_time()
from robokit.cli import main
t1 = time.perf_counter()
from robokit.plugins import load_plugins
lazy = load_plugins()
t2 = time.perf_counter()
from robokit.config import load_config
cfg = load_config({str(config)!r}, lazy)
t3 = time.perf_counter()
from robokit.runner import run_config
out = run_config(cfg, lazy)
t4 = time.perf_counter()
eager = load_plugins(lazy=False)
t5 = time.perf_counter()
print(f"  import robokit.cli {{(t1 - t0) * 1e3:6.1f}} ms | plugins (lazy) {{(t2 - t1) * 1e3:6.1f}} ms | "
      f"config {{(t3 - t2) * 1e3:6.1f}} ms | build + run + report {{(t4 - t3) * 1e3:6.1f}} ms | "
      f"then every plugin (eager) {{(t5 - t4) * 1e3:6.1f}} ms")
"""
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.run([sys.executable, "-c", code], cwd=tmp, capture_output=True, text=True)
    print(proc.stdout.rstrip() or proc.stderr.strip()[-400:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10)
    args = parser.parse_args()
    exe = str(Path(sys.executable).parent / "robokit")
    with tempfile.TemporaryDirectory() as tmp:
        trivial = Path(tmp) / "trivial.toml"
        trivial.write_text(TRIVIAL)
        cases = {
            "python -c pass": [sys.executable, "-c", "pass"],
            "robokit --help": [exe, "--help"],
            "robokit run trivial.toml": [exe, "run", str(trivial), "--quiet"],
            "robokit run patrol_robot.toml (0.05 s)": [exe, "run", str(ROOT / "configs" / "patrol_robot.toml"),
                                                       "--max-time", "0.05", "--quiet"],
            "robokit plugins": [exe, "plugins"],
        }
        print(f"load: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1/5/15 min) on {os.cpu_count()} cores; "
              f"{args.repeats} runs each, interleaved; medians", flush=True)
        samples: dict[str, list[tuple[float, float]]] = {name: [] for name in cases}
        for _ in range(args.repeats):
            for name, cmd in cases.items():
                samples[name].append(measure(cmd, tmp))
        for name, runs in samples.items():
            cpu = statistics.median(r[0] for r in runs)
            wall = statistics.median(r[1] for r in runs)
            note = "  (target < 200 ms)" if name == "robokit run trivial.toml" else ""
            print(f"{name:<40} process {cpu * 1e3:6.0f} ms   wall {wall * 1e3:6.0f} ms{note}")
        for argv in (["--help"], ["run", str(trivial), "--quiet"]):
            probe = subprocess.run([sys.executable, "-c", PROBE.format(heavy=HEAVY), *argv], cwd=tmp,
                                   capture_output=True, text=True)
            print(f"robokit {argv[0]}: {probe.stderr.strip().splitlines()[-1]}")
        print("inside a trivial run (one fresh process):")
        in_process(trivial)


if __name__ == "__main__":
    main()
