"""Patrol-and-collect benchmark: success over many seeds, and what the lidar costs.

    python benchmarks/patrol.py --trials 100 --workers 2

Per seed (each seed is a different random layout of the cans) it runs ``configs/patrol_robot.toml`` headless and
prints: the share of runs that reached every waypoint with zero collisions, the share of objects collected, the
median localisation error of the logged object positions, and the real-time factor. Then it measures the cost of a
360-ray lidar at 10 Hz: the same scene and the same scripted drive, once with the lidar read at every scan and
twice without the lidar, all alive in this one process and stepped a quarter of a sim second each in turn, so that
a host whose speed drifts treats them alike. It prints the ratio of wall times to the runs without the lidar (the
median over ``--repeats`` passes; also process CPU, user-mode instructions, the spread of the per-chunk ratios, the
load average, and per scan its process time and instructions) and the two runs without the lidar against each
other: the yardstick's own error. ``--reference`` adds the lidar with every ray cast by PyBullet.
"""

from __future__ import annotations

import argparse
import copy
import ctypes
import os
import platform
import random
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


def lidar_cost(config: Path, seconds: float, repeats: int, threads: int = 1, reference: bool = False,
               chunk_seconds: float = 0.25) -> list[dict[str, dict[str, Any]]]:
    """What the lidar costs, measured with the variants side by side in this one process.

    Variants: the lidar (map intersected in numpy), with ``reference`` also every ray cast by PyBullet, the run
    without the lidar, and a control: the run without the lidar once more. All their sims are alive at once and
    are stepped ``chunk_seconds`` of sim time each in turn (in a new seeded random order every round, so that no
    variant always follows the same one and inherits its traces in the CPU's caches) until each has run
    ``seconds``, so every variant meets the host in the same state: on a shared host whose speed drifts by tens of
    per cent within a minute, whole runs one after another do not. The baseline is the mean of the two runs
    without the lidar; their ratio to each other shows how far the yardstick itself is off (1.00 if exact).
    ``repeats`` passes, each with fresh sims.

    Per pass and variant: wall and process-CPU seconds summed over the chunks, the per-chunk ratios to the run
    without the lidar, user-mode instructions (where Linux counts them; the same on any load), and for the lidar
    the time and instructions inside its scans and the share of rays PyBullet cast."""
    import contextlib

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
    variants["control"] = copy.deepcopy(variants["without"])
    count = _instruction_counter()
    shuffle = random.Random(0).shuffle
    passes = []
    for _ in range(repeats):
        with contextlib.ExitStack() as stack:
            sims = {label: stack.enter_context(make_sim(cfg, extra_plugins=[ScriptedPlugin()],
                                                        base_dir=config.parent))
                    for label, cfg in variants.items()}
            step = sims["with"].world.time_step
            ticks, chunk = round(seconds / step), max(1, round(chunk_seconds / step))
            in_scans = {label: _time_scans(sim.components.get("scan")) for label, sim in sims.items()}
            out: dict[str, dict[str, Any]] = {
                label: {"wall": 0.0, "cpu": 0.0, "instr": 0.0, "ticks": ticks, "chunks": []} for label in sims}
            labels = list(sims)
            done = 0
            while done < ticks:
                n = min(chunk, ticks - done)
                shuffle(labels)
                for label in labels:
                    t0, c0, i0 = time.perf_counter(), time.process_time(), count()
                    sims[label].step(n)
                    wall, cpu, instr = time.perf_counter() - t0, time.process_time() - c0, count() - i0
                    o = out[label]
                    o["wall"] += wall
                    o["cpu"] += cpu
                    o["instr"] += instr
                    o["chunks"].append(cpu)
                done += n
            for label, sim in sims.items():
                o = out[label]
                if "scan" in sim.components:
                    lidar = sim.components["scan"]
                    o["cast"] = lidar.caster.rays_cast / max(lidar.caster.rays_total, 1)
                    o["scan_ms"] = 1000.0 * in_scans[label][0] / max(lidar.scans, 1)
                    o["scan_minstr"] = in_scans[label][1] / max(lidar.scans, 1) / 1e6
                    o["tick_us"] = 1e6 * (o["cpu"] - in_scans[label][0]) / ticks
        passes.append(out)
    return passes


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
    parser.add_argument("--cost-seconds", type=float, default=30.0, help="sim seconds per variant of the lidar cost")
    parser.add_argument("--chunk-seconds", type=float, default=0.25,
                        help="sim seconds each variant runs before the next one's turn")
    parser.add_argument("--repeats", type=int, default=3,
                        help="passes of the lidar cost, each with fresh sims (the median ratio is reported)")
    parser.add_argument("--skip-cost", action="store_true")
    parser.add_argument("--lidar-threads", type=int, default=1, help="rayTestBatch threads for the cost run")
    parser.add_argument("--reference", action="store_true",
                        help="also time the lidar with every ray cast by PyBullet (map_in_numpy = false)")
    args = parser.parse_args(argv)

    if args.trials > 0:
        report_trials(args)
    if not args.skip_cost:
        passes = lidar_cost(args.config, args.cost_seconds, args.repeats, args.lidar_threads, args.reference,
                            args.chunk_seconds)
        report_cost(passes, args)
    return 0


def report_cost(passes: list[dict[str, dict[str, Any]]], args: argparse.Namespace) -> None:
    """Print the lidar cost: per variant, the median over the passes of the ratio of its summed time to the run
    without the lidar (the mean of that run and its control), the spread of the per-chunk ratios, instructions,
    what a scan costs; and the control's ratio to the run without the lidar (the yardstick's own error)."""
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"lidar cost, {args.cost_seconds:g} sim s per variant in chunks of {args.chunk_seconds:g} sim s, variants "
          f"interleaved in one process, {len(passes)} pass(es), {args.lidar_threads} ray thread(s), "
          f"load average {load}:")

    def base(p: dict[str, dict[str, Any]], key: str) -> Any:
        if key == "chunks":
            return [(a + b) / 2 for a, b in zip(p["without"]["chunks"], p["control"]["chunks"], strict=True)]
        return (p["without"][key] + p["control"][key]) / 2

    def ratio(label: str, key: str, against: Any = base) -> float:
        return statistics.median(p[label][key] / against(p, key) for p in passes)

    def only_without(p: dict[str, dict[str, Any]], key: str) -> Any:
        return p["without"][key]

    for label, text in (("with", "360 rays @ 10 Hz, map in numpy"),
                        ("pybullet", "360 rays @ 10 Hz, every ray by PyBullet")):
        if label not in passes[0]:
            continue
        chunks = sorted(a / b for p in passes for a, b in zip(p[label]["chunks"], base(p, "chunks"), strict=True))
        p10, p50, p90 = (chunks[int(q * (len(chunks) - 1))] for q in (0.1, 0.5, 0.9))
        each = ", ".join(f"{p[label]['wall'] / base(p, 'wall'):.3f}" for p in passes)
        instructions = (f", user instructions {ratio(label, 'instr'):.3f}" if passes[0]["without"]["instr"] > 0
                        else "")
        print(f"  {text}: ratio {ratio(label, 'wall'):.3f} in wall time (passes: {each}); process CPU "
              f"{ratio(label, 'cpu'):.3f}{instructions}; per chunk median {p50:.3f} (p10-p90 {p10:.3f}-{p90:.3f})"
              "   (target <= 1.15)")
        b = passes[-1][label]
        scan_ms = statistics.median(p[label]["scan_ms"] for p in passes)
        tick_us = statistics.median(p[label]["tick_us"] for p in passes)
        base_us = statistics.median(1e6 * base(p, "cpu") / p["without"]["ticks"] for p in passes)
        minstr = f"{b['scan_minstr']:.2f} M" if b["scan_minstr"] > 0 else "n/a"
        print(f"    a scan {scan_ms:.2f} ms of process time ({minstr} user instructions); the rest of a tick "
              f"{tick_us:.0f} us (without the lidar {base_us:.0f} us); PyBullet cast {b['cast']:.1%} of the rays")
    each = ", ".join(f"{p['control']['wall'] / p['without']['wall']:.3f}" for p in passes)
    error = ratio("control", "wall", only_without)
    print(f"  the yardstick's own error: the run without the lidar, twice: ratio {error:.3f} (passes: {each})"
          f"   (1.00 if the host treated every variant alike)")


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
