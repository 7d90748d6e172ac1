"""Patrol-and-collect benchmark: success over many seeds, and what the lidar costs.

    python benchmarks/patrol.py --trials 100 --workers 2

Per seed (each seed is a different random layout of the cans) it runs ``configs/patrol_robot.toml`` headless and
prints: the share of runs that reached every waypoint with zero collisions, the share of objects collected, the
median localisation error of the logged object positions, and the real-time factor. Then it measures the cost of a
360-ray lidar at 10 Hz: the same scene and the same scripted drive, once with the lidar read at every scan and
once without the lidar, as a ratio of wall times (best of ``--repeats`` interleaved runs; the process-CPU ratio is
printed too, and the load average; per scan, its process time and user-mode instructions). ``--reference`` adds
the lidar with every ray cast by PyBullet.
"""

from __future__ import annotations

import argparse
import copy
import ctypes
import math
import os
import platform
import statistics
import struct
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "patrol_robot.toml"


def measure(sim: Any, result: Any) -> dict[str, Any]:
    """After a trial: how many objects there were, whether the patrol was complete, the localisation errors."""
    r = result.result
    return {
        "objects": len(sim.components["truth"].names),
        "complete": r.get("waypoints_reached") == r.get("waypoints_total") and r.get("collisions") == 0,
        "errors": [f["error"] for f in r.get("found", []) if "error" in f],
    }


def trials(config: Path, seeds: range, workers: int) -> list[dict[str, Any]]:
    """Run the seeds through the sweep engine; one figure dict per seed."""
    from robokit.sweep import SweepOptions, SweepSpec, run_sweep

    run = run_sweep(SweepSpec(config, seeds), SweepOptions(workers=workers, after=measure))
    return [{
        "seed": r["seed"], "outcome": r["outcome"], "sim_time": r["sim_time"] or 0.0, "wall": r["run_wall_time"],
        "complete": bool(r["figures"].get("complete")), "collisions": r["figures"].get("collisions", 0),
        "objects": r["figures"].get("objects", 0), "collected": r["figures"].get("objects_collected", 0),
        "found": r["figures"].get("objects_found", 0), "errors": r["figures"].get("errors", []),
    } for r in run.rows]


class ScriptedDrive:
    """Benchmark-only behaviour: drives a fixed circle and, if there is a lidar, reads it every step."""

    kind = "behaviour"

    def __init__(self, name: str, config: Any) -> None:
        self.name, self.config, self.outcome = name, config, None

    def setup(self, ctx: Any) -> None:
        self.scan = "scan" in ctx.components

    def step(self, readings: Any, t: float) -> Any:
        from robokit.msgs.mobile import Twist

        if self.scan:
            readings["scan"]  # noqa: B018 - computes the scan when it is due (10 Hz)
        return {"drive": Twist(0.3, 0.4)}  # a 0.75 m circle round (0, 0.75): clear of the boxes and walls

    def result(self) -> dict[str, Any]:
        return {}

    def close(self) -> None:
        pass


class ScriptedPlugin:
    """Registers :class:`ScriptedDrive` as ``scripted_drive``."""

    from robokit import hookimpl

    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("scripted_drive", ScriptedDrive, None)


def lidar_cost(config: Path, seconds: float, repeats: int, threads: int = 1,
               reference: bool = False) -> dict[str, dict[str, float]]:
    """Wall and process-CPU seconds (and user-mode instructions, where Linux counts them: the same on any load) of
    ``seconds`` sim seconds with the lidar (map intersected in numpy, and with
    ``reference`` also with every ray cast by PyBullet) and without it: best of ``repeats`` interleaved runs, the
    order of the variants turned round at each repeat. Also the share of rays PyBullet cast."""
    from robokit.config import read_toml
    from robokit.testing import make_sim

    raw = read_toml(config)
    raw["behaviour"] = {"type": "scripted_drive", "rate_hz": 20}
    raw["sensors"]["scan"]["num_threads"] = threads
    variants = {"with": raw}
    if reference:
        variants["pybullet"] = copy.deepcopy(raw)
        variants["pybullet"]["sensors"]["scan"]["map_in_numpy"] = False
    variants["without"] = copy.deepcopy(raw)
    del variants["without"]["sensors"]["scan"]
    best = {label: {"wall": math.inf, "cpu": math.inf, "cast": 1.0} for label in variants}
    for rep in range(repeats):
        order = list(variants) if rep % 2 == 0 else list(reversed(variants))
        for label in order:
            with make_sim(variants[label], extra_plugins=[ScriptedPlugin()], base_dir=config.parent) as sim:
                ticks = round(seconds / sim.world.time_step)
                in_scans = _time_scans(sim.components.get("scan"))
                count = _instruction_counter()
                t0, c0, i0 = time.perf_counter(), time.process_time(), count()
                sim.step(ticks)
                wall, cpu, instr = time.perf_counter() - t0, time.process_time() - c0, count() - i0
                b = best[label]
                b["wall"], b["cpu"], b["ticks"] = min(b["wall"], wall), min(b["cpu"], cpu), ticks
                b["instr"] = min(b.get("instr", math.inf), instr)
                if "scan" in sim.components:
                    lidar = sim.components["scan"]
                    b["cast"] = lidar.caster.rays_cast / max(lidar.caster.rays_total, 1)
                    b["scan_ms"] = min(b.get("scan_ms", math.inf), 1000.0 * in_scans[0] / max(lidar.scans, 1))
                    b["scan_minstr"] = in_scans[1] / max(lidar.scans, 1) / 1e6
                    b["tick_us"] = 1e6 * (cpu - in_scans[0]) / ticks
    return best


def _time_scans(lidar: Any) -> list[float]:
    """Wrap ``lidar.read`` (the instance's) to add up the process time spent in it and, where Linux lets this
    process count them, its user-mode instructions (0 otherwise); returns the running totals [seconds, instructions]."""
    total = [0.0, 0.0]
    if lidar is None:
        return total
    read, count = lidar.read, _instruction_counter()

    def timed() -> Any:
        c0, i0 = time.process_time(), count()
        try:
            return read()
        finally:
            total[0] += time.process_time() - c0
            total[1] += count() - i0

    lidar.read = timed
    return total


_COUNTER: list[Callable[[], float]] = []


def _instruction_counter() -> Callable[[], float]:
    """User-mode instructions this thread has executed, through ``perf_event_open``, scaled by the share of time
    the counter ran (other processes' counters can crowd it out); a function returning 0 where that is refused.
    One counter per process (each open counter takes a slot of the CPU's few)."""
    if _COUNTER:
        return _COUNTER[0]
    from _counters import _SYSCALL, _Attr

    number = _SYSCALL.get(platform.machine())
    fd = -1
    if number is not None and os.name == "posix":
        attr = _Attr(type=0, size=ctypes.sizeof(_Attr), config=1, read_format=3, flags=(1 << 5) | (1 << 6))
        fd = ctypes.CDLL(None, use_errno=True).syscall(number, ctypes.byref(attr), 0, -1, -1, 0)

    def read() -> float:
        if fd < 0:
            return 0.0
        value, enabled, running = struct.unpack("QQQ", os.read(fd, 24))
        return value * enabled / running if running else 0.0

    _COUNTER.append(read)
    return read


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=20, help="seeds to run")
    parser.add_argument("--start-seed", type=int, default=0, help="first seed")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the sweep engine")
    parser.add_argument("--config", type=Path, default=CONFIG)
    parser.add_argument("--cost-seconds", type=float, default=30.0, help="sim seconds per lidar cost run")
    parser.add_argument("--repeats", type=int, default=3, help="lidar cost runs per variant (best is kept)")
    parser.add_argument("--skip-cost", action="store_true")
    parser.add_argument("--lidar-threads", type=int, default=1, help="rayTestBatch threads for the cost run")
    parser.add_argument("--reference", action="store_true",
                        help="also time the lidar with every ray cast by PyBullet (map_in_numpy = false)")
    args = parser.parse_args(argv)

    if args.trials > 0:
        report_trials(args)
    if not args.skip_cost:
        best = lidar_cost(args.config, args.cost_seconds, args.repeats, args.lidar_threads, args.reference)
        base = best["without"]
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
        print(f"lidar cost, {args.cost_seconds:g} sim s, best of {args.repeats} interleaved runs, "
              f"{args.lidar_threads} ray thread(s), load average {load}:")
        for label, text in (("with", "360 rays @ 10 Hz, map in numpy"),
                            ("pybullet", "360 rays @ 10 Hz, every ray by PyBullet")):
            if label in best:
                b = best[label]
                print(f"  {text}: {b['wall']:.2f} s vs {base['wall']:.2f} s without: "
                      f"ratio {b['wall'] / base['wall']:.3f} (process CPU {b['cpu'] / base['cpu']:.3f}"
                      + (f", user instructions {b['instr'] / base['instr']:.3f}" if base["instr"] > 0 else "")
                      + "); "
                      f"PyBullet cast {b['cast']:.1%} of the rays   (target <= 1.15)")
                instructions = f"{b['scan_minstr']:.2f} M" if b["scan_minstr"] > 0 else "n/a"
                print(f"    a scan {b['scan_ms']:.2f} ms of process time ({instructions} user instructions); "
                      f"the rest of a tick {b['tick_us']:.0f} us "
                      f"(without the lidar {1e6 * base['cpu'] / base['ticks']:.0f} us)")
    return 0


def report_trials(args: argparse.Namespace) -> None:
    """Run the seeds in worker processes and print the aggregate figures."""
    rows = trials(args.config, range(args.start_seed, args.start_seed + args.trials), args.workers)
    complete = sum(r["complete"] for r in rows)
    objects, collected = sum(r["objects"] for r in rows), sum(r["collected"] for r in rows)
    errors = [e for r in rows for e in r["errors"]]
    rtf = sum(r["sim_time"] for r in rows) / sum(r["wall"] for r in rows)
    print(f"trials: {len(rows)} seeds ({rows[0]['seed']}..{rows[-1]['seed']}) of {args.config.name}")
    print(f"every waypoint, zero collisions: {complete}/{len(rows)} = {complete / len(rows):.1%}   (target >= 95%)")
    print(f"objects collected: {collected}/{objects} = {collected / objects:.1%}   (target >= 95%)")
    print(f"objects found: {sum(r['found'] for r in rows)}/{objects}")
    if errors:
        print(f"localisation error: median {statistics.median(errors) * 100:.2f} cm, max {max(errors) * 100:.2f} cm"
              f"   (target median <= 5 cm)")
    print(f"collisions: {sum(r['collisions'] for r in rows)} in total; mean sim time "
          f"{statistics.mean(r['sim_time'] for r in rows):.1f} s; real-time factor {rtf:.1f}x per worker")
    bad = [r["seed"] for r in rows if not r["complete"] or r["collected"] < r["objects"]]
    if bad:
        print(f"seeds not perfect: {bad}")


if __name__ == "__main__":
    sys.exit(main())
