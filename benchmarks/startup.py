"""Start-up cost of the ``robokit`` command: process time (user + system CPU of every thread) of whole processes.

Measured, each as the median of ``--repeats`` fresh processes, interleaved (one of each per round):

- ``python -c pass``: the interpreter alone;
- ``python -c 'import numpy, pybullet'``: the floor of any run (both are needed to simulate anything);
- the same trivial job written by hand: numpy's generator, a DIRECT client, plane + box, 24 steps, a JSON file;
- the same plus ``pydantic`` and ``pluggy``: what robokit's start-up cost when every config was validated with
  pydantic (a trivial run now imports no pydantic: its sections have light schemas, see ``robokit.config.sections``);
- ``robokit --help``: must import neither numpy, pybullet nor OpenCV (checked below);
- ``robokit run TRIVIAL --quiet``: a plane and a falling box for 0.1 sim seconds with the default record (trace,
  pose log, ``result.json``) — target: under 200 ms of process time; then the same as the first run after an
  install, when the plugins' entry points are asked of ``importlib.metadata`` (a cache folder that cannot be written:
  see ``robokit.plugin_api.entry_points``);
- ``robokit run configs/patrol_robot.toml --max-time 0.05 --quiet``: a real config's start-up (no OpenCV);
- ``robokit plugins``: lists every type, so it imports every plugin module.

The floors run with the same environment as ``robokit`` (``robokit`` sets ``OPENBLAS_NUM_THREADS=1`` for itself
unless it is set: OpenBLAS's idle worker thread otherwise spins for ~0.1 s of CPU after numpy's import), so the
figures compare like with like; ``--blas-threads`` shows the floor with OpenBLAS's default threads too.

Children run with bytecode caching on (``PYTHONDONTWRITEBYTECODE`` removed) after one warm-up round, as an
installed robokit runs: ``pip install`` compiles the package, an editable install caches on its first run.

Instructions — the issue's yardstick, the same on any load — come from the hardware counters where the host gives
them (``benchmarks/_counters.py``), else from ``valgrind --tool=callgrind`` (one run of each case, with
``PYTHONHASHSEED=0``; about 10 s a case): the job by hand, the trivial run, and the first run after an install.

Then, in fresh processes, where a trivial run's process time goes, stage by stage (median over the repeats).

    python benchmarks/startup.py [--repeats 15] [--against 71958b6] [--blas-threads] [--no-callgrind]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

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
HEAVY = ("numpy", "pybullet", "cv2", "pydantic", "transitions", "requests", "importlib.metadata", "email")
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
STAGES = """
import json, os, sys, time
clock = time.process_time
counter = None
if os.environ.get("STAGE_INSTRUCTIONS"):  # user-mode instructions too; the counter's own imports are then undone
    before = set(sys.modules)
    sys.path.insert(0, os.environ["STAGE_INSTRUCTIONS"])
    from _counters import Counters
    counter = Counters.open()
    sys.path.pop(0)
    for name in set(sys.modules) - before:
        del sys.modules[name]
def mark(name):
    marks.append((name, clock(), counter.read()[1] if counter is not None else 0))
marks = []
mark("interpreter start-up (before the first line)")
import robokit.cli as cli
mark("import robokit.cli")
cli._pause_gc_for_startup()  # as the robokit command does
argv = ["run", sys.argv[1], "--quiet"]
args = cli._parser("run").parse_args(argv)
from robokit.process.quiet import capture_c_stdout
from robokit.process.interrupts import StopGuard
mark("command line, output capture, signal guard")
from robokit.plugin_api.plugins import load_plugins
plugins = load_plugins()
mark("plugin discovery (numpy, pybullet; entry points)")
from robokit.config import load_config
mark("import robokit.config (core sections, tomllib)")
cfg = load_config(args.config, plugins)
mark("config read + validation (+ local reporter module)")
from robokit.runner import run_config, summary
mark("import robokit.runner (simulation, world)")
cli._end_startup_gc_pause()
out = run_config(cfg, plugins, max_time=None, on_problem=None)
mark("build + run + record + report")
summary(out)
print(json.dumps(marks))
"""
BY_HAND = """
import json, os, uuid
import numpy as np
import pybullet as p
import pybullet_data
rng = np.random.default_rng(0)
cid = p.connect(p.DIRECT)
p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
p.setGravity(0, 0, -9.81, physicsClientId=cid)
p.loadURDF("plane.urdf", physicsClientId=cid)
shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.05] * 3, physicsClientId=cid)
box = p.createMultiBody(1.0, shape, basePosition=[0, 0, 0.5], physicsClientId=cid)
for _ in range(24):
    p.stepSimulation(physicsClientId=cid)
pos, _ = p.getBasePositionAndOrientation(box, physicsClientId=cid)
os.makedirs("byhand", exist_ok=True)
with open(os.path.join("byhand", f"{uuid.uuid4()}.json"), "w") as fh:
    json.dump({"z": pos[2]}, fh)
p.disconnect(cid)
"""


def child_env(blas_threads: bool = False) -> dict[str, str]:
    """The environment of every measured child: bytecode caching on, and (like ``robokit``) one OpenBLAS thread
    unless ``blas_threads`` or the caller set ``OPENBLAS_NUM_THREADS``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if not blas_threads:
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
    else:
        env.pop("OPENBLAS_NUM_THREADS", None)
    return env


_COUNTERS: list[Any] = []


def _instructions() -> float:
    """User-mode instructions of this process and its reaped children so far (``perf_event_open`` with inherit:
    a child's count is added when it ends); 0 where Linux refuses the counter."""
    if not _COUNTERS:
        from _counters import Counters

        _COUNTERS.append(Counters.open())
    return float(_COUNTERS[0].read()[1]) if _COUNTERS[0] is not None else 0.0


def measure(cmd: list[str], cwd: str, env: dict[str, str]) -> tuple[float, float, float]:
    """(process seconds, wall seconds, user-mode instructions) of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    i0 = _instructions()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    instructions = _instructions() - i0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, instructions


def callgrind(cmd: list[str], cwd: str, env: dict[str, str]) -> float | None:
    """Instructions of one run of ``cmd`` as valgrind's callgrind counts them (None without valgrind)."""
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        return None
    proc = subprocess.run([valgrind, "--tool=callgrind", "--callgrind-out-file=/dev/null", *cmd], cwd=cwd,
                          capture_output=True, text=True, env={**env, "PYTHONHASHSEED": "0"})
    found = re.search(r"Collected : (\d+)", proc.stderr)
    if proc.returncode not in (0, 1) or found is None:
        raise SystemExit(f"callgrind of {' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip()[-400:]}")
    return float(found.group(1))


def stages(config: Path, repeats: int, cwd: str, env: dict[str, str]) -> None:
    """Where a trivial run's process time (and user-mode instructions) go: each stage of what ``robokit run`` does,
    in fresh processes. The counter is opened before the first mark: its small cost lands in no stage."""
    env = {**env, "STAGE_INSTRUCTIONS": str(Path(__file__).resolve().parent)} if _instructions() > 0 else env
    per_stage: dict[str, list[tuple[float, float]]] = {}
    for _ in range(repeats):
        proc = subprocess.run([sys.executable, "-c", STAGES, str(config)], cwd=cwd, capture_output=True,
                              text=True, env=env)
        if proc.returncode != 0:
            print(f"  (stage breakdown failed: {proc.stderr.strip()[-400:]})")
            return
        marks = json.loads(proc.stdout.strip().splitlines()[-1])
        previous = (0.0, float(marks[0][2]))
        for name, t, instructions in marks:
            per_stage.setdefault(name, []).append((t - previous[0], instructions - previous[1]))
            previous = (t, float(instructions))
    total = [0.0, 0.0]
    for name, values in per_stage.items():
        ms = statistics.median(v[0] for v in values) * 1e3
        mi = statistics.median(v[1] for v in values) / 1e6
        total[0] += ms
        total[1] += mi
        shown = f"  {mi:6.1f} M instructions" if mi > 0 else ""
        print(f"  {name:<58} {ms:6.1f} ms{shown}")
    shown = f"  {total[1]:6.1f} M" if total[1] > 0 else ""
    print(f"  {'sum of the medians (interpreter exit not included)':<58} {total[0]:6.1f} ms{shown}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--blas-threads", action="store_true",
                        help="also measure the numpy + pybullet floor with OpenBLAS's default thread count")
    parser.add_argument("--no-callgrind", action="store_true",
                        help="where the host has no hardware counters, skip counting instructions under valgrind")
    parser.add_argument("--against", metavar="REV",
                        help="also run the trivial config with robokit/ as it was at git revision REV (its "
                             "package from `git archive`, plugins from this checkout), interleaved; prints the ratio")
    args = parser.parse_args()
    exe = str(Path(sys.executable).parent / "robokit")
    py = sys.executable
    env = child_env()
    with tempfile.TemporaryDirectory() as tmp:
        trivial = Path(tmp) / "trivial.toml"
        trivial.write_text(TRIVIAL)
        cases: dict[str, tuple[list[str], dict[str, str]]] = {
            "python -c pass": ([py, "-c", "pass"], env),
            "python -c 'import numpy, pybullet'  (floor)": ([py, "-c", "import numpy, pybullet"], env),
            "the same job by hand (pybullet, numpy rng, json)": ([py, "-c", BY_HAND], env),
            "  + pydantic, pluggy (robokit's libraries)": (
                [py, "-c", "import numpy, pybullet, pluggy; from pydantic import BaseModel, Field"], env),
            "robokit --help": ([exe, "--help"], env),
            "robokit run trivial.toml": ([exe, "run", str(trivial), "--quiet"], env),
            "  the same, entry points not remembered": (  # the first run after an install: importlib.metadata asked
                [exe, "run", str(trivial), "--quiet"], {**env, "ROBOKIT_CACHE_DIR": os.devnull + "/robokit"}),
            "robokit run patrol_robot.toml (0.05 s)": (
                [exe, "run", str(ROOT / "configs" / "patrol_robot.toml"), "--max-time", "0.05", "--quiet"], env),
            "robokit plugins": ([exe, "plugins"], env),
        }
        if args.against:
            old = Path(tmp) / "against"
            old.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.against, "robokit"],
                                     capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
            for label, pythonpath in ((f"robokit run trivial.toml at {args.against}", str(old)),
                                      ("robokit run trivial.toml (python -m)", "")):
                cases[label] = ([py, "-m", "robokit.cli", "run", str(trivial), "--quiet"],
                                {**child_env(blas_threads=True), "PYTHONPATH": pythonpath})
        if args.blas_threads:
            cases["numpy, pybullet with OpenBLAS's own threads"] = (
                [py, "-c", "import numpy, pybullet"], child_env(blas_threads=True))
        for cmd, cenv in cases.values():  # warm-up: bytecode caches written, files in the page cache
            measure(cmd, tmp, cenv)
        print(f"load: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1/5/15 min) on {os.cpu_count()} cores; "
              f"{args.repeats} runs each, interleaved; medians of process time (user + system, all threads)",
              flush=True)
        samples: dict[str, list[tuple[float, float, float]]] = {name: [] for name in cases}
        for _ in range(args.repeats):
            for name, (cmd, cenv) in cases.items():
                samples[name].append(measure(cmd, tmp, cenv))
        medians = {name: statistics.median(r[0] for r in runs) for name, runs in samples.items()}
        for name, runs in samples.items():
            cpu = sorted(r[0] for r in runs)
            wall = statistics.median(r[1] for r in runs)
            instr = statistics.median(r[2] for r in runs)
            shown = f"  {instr / 1e6:5.0f} M instructions" if instr > 0 else ""
            note = "  (target < 200 ms)" if name == "robokit run trivial.toml" else ""
            print(f"{name:<46} process {medians[name] * 1e3:6.0f} ms (p10-p90 {cpu[len(cpu) // 10] * 1e3:4.0f}-"
                  f"{cpu[-1 - len(cpu) // 10] * 1e3:4.0f})   wall {wall * 1e3:6.0f} ms{shown}{note}")
        instructions = {name: statistics.median(r[2] for r in runs) for name, runs in samples.items()}
        run = medians["robokit run trivial.toml"]
        floor = medians["python -c 'import numpy, pybullet'  (floor)"]
        by_hand = medians["the same job by hand (pybullet, numpy rng, json)"]
        libs = medians["  + pydantic, pluggy (robokit's libraries)"]
        print(f"trivial run: {run / by_hand:.2f}x the same job by hand ({(run - by_hand) * 1e3:+.0f} ms); "
              f"{(run - floor) * 1e3:.0f} ms above the numpy + pybullet import floor, {(run - libs) * 1e3:.0f} ms "
              f"above that floor plus pydantic and pluggy; load now {os.getloadavg()[0]:.2f}")
        cold = medians["  the same, entry points not remembered"]
        print(f"  the first run after an install (entry points asked of importlib.metadata): {cold / by_hand:.2f}x "
              f"the job by hand ({(cold - run) * 1e3:+.0f} ms against a later run)")
        hand_i = instructions["the same job by hand (pybullet, numpy rng, json)"]
        if hand_i > 0:  # the work done, the same on any load: process time scales with it on a given machine
            run_i = instructions["robokit run trivial.toml"]
            print(f"trivial run in user-mode instructions: {run_i / hand_i:.2f}x the same job by hand "
                  f"({run_i / 1e6:.0f} M against {hand_i / 1e6:.0f} M); at the by-hand job's measured process time "
                  f"that would be {by_hand * run_i / hand_i * 1e3:.0f} ms")
        if hand_i == 0 and not args.no_callgrind:
            counted = {name: callgrind(cases[name][0], tmp, cases[name][1]) for name in (
                "the same job by hand (pybullet, numpy rng, json)", "robokit run trivial.toml",
                "  the same, entry points not remembered")}
            hand_c, run_c, cold_c = counted.values()
            if hand_c and run_c and cold_c:
                print(f"trivial run in instructions (callgrind, no hardware counters here): {run_c / hand_c:.3f}x the "
                      f"same job by hand ({run_c / 1e6:.1f} M against {hand_c / 1e6:.1f} M; target <= 1.20); the first "
                      f"run after an install {cold_c / hand_c:.3f}x ({cold_c / 1e6:.1f} M)")
            else:
                print("instructions: no hardware counters and no valgrind here (apt-get install valgrind)")
        if args.against:
            before = medians[f"robokit run trivial.toml at {args.against}"]
            now = medians["robokit run trivial.toml (python -m)"]
            print(f"trivial run, this checkout / {args.against}: {now / before:.3f} ({now * 1e3:.0f} ms against "
                  f"{before * 1e3:.0f} ms; both `python -m robokit.cli`, OPENBLAS_NUM_THREADS left unset)")
            old_i = instructions[f"robokit run trivial.toml at {args.against}"]
            if old_i > 0:
                new_i = instructions["robokit run trivial.toml (python -m)"]
                print(f"  in user-mode instructions: {new_i / old_i:.3f} "
                      f"({new_i / 1e6:.0f} M against {old_i / 1e6:.0f} M)")
        for argv in (["--help"], ["run", str(trivial), "--quiet"]):
            for _ in range(2):  # the second: as every run after the first (the entry points are remembered)
                probe = subprocess.run([py, "-c", PROBE.format(heavy=HEAVY), *argv], cwd=tmp, capture_output=True,
                                       text=True, env=env)
            print(f"robokit {argv[0]}: {probe.stderr.strip().splitlines()[-1]}")
        print(f"inside a trivial run, per stage (fresh processes, median of {args.repeats}; the interpreter's own "
              "start-up is counted in the first stage's time only):")
        stages(trivial, args.repeats, tmp, env)


if __name__ == "__main__":
    main()
