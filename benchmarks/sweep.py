"""Sweep engine benchmark: local speed-up with workers, the Ray backend's per-trial overhead, a worker's memory.

    python benchmarks/sweep.py --trials 12 --repeats 2          # 1 vs 2 local workers, then Ray vs local (sort)
    python benchmarks/sweep.py --skip-speed --skip-ray --memory-trials 500   # RSS of one worker over 500 trials
    python benchmarks/sweep.py --skip-speed --skip-ray --memory-trials 500 --memory-max-time 0.5   # cheaper

1. **Speed-up**: the same ``--trials`` seeds of ``configs/sort_robot.toml`` through ``run_sweep`` with 1 and with 2
   local workers, alternated ``--repeats`` times (best of each kept); trials per second and their ratio (target on 2
   idle cores: >= 1.8). Worker start-up (spawn: a fresh interpreter importing robokit) is included.
2. **Ray overhead**: the same trials on 2 local workers and on a private 2-CPU Ray (started once, before timing),
   alternated; wall seconds per trial and the Ray/local ratio (target <= 1.05).
3. **Memory**: one local worker (never recycled) runs ``--memory-trials`` trials of ``--memory-config``; each trial
   reports the worker's resident set size (VmRSS) after it; growth from trial 10 to the last (target < 50 MB).

Every figure is a ratio or a difference measured in this one invocation; the machine's load (``os.getloadavg``)
is printed with them: re-measure on an idle machine before quoting a speed-up.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SORT = ROOT / "configs" / "sort_robot.toml"
PICK = ROOT / "configs" / "pick_place.toml"


def rss_mb(sim: Any, result: Any) -> dict[str, Any]:
    """After-hook: this worker's resident set size in MB and its pid (read from /proc/self/status)."""
    with open("/proc/self/status", encoding="ascii") as fh:
        kb = next(int(line.split()[1]) for line in fh if line.startswith("VmRSS:"))
    return {"rss_mb": kb / 1024.0, "pid": os.getpid()}


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} CPUs"


def timed_sweep(config: Path, seeds: range, fixed: dict[str, Any] | None = None,
                **options: Any) -> tuple[float, list[dict[str, Any]]]:
    """Wall seconds of one ``run_sweep`` (no output folder) and its rows."""
    from robokit.sweep import SweepOptions, SweepSpec, run_sweep

    t0 = time.perf_counter()
    run = run_sweep(SweepSpec(config, seeds, fixed=fixed or {}), SweepOptions(**options))
    wall = time.perf_counter() - t0
    bad = [r for r in run.rows if r["outcome"] not in ("succeeded", "aborted" if fixed else "succeeded")]
    if bad:
        print(f"  warning: {len(bad)} trial(s) did not succeed: {bad[0]['reason']}")
    return wall, run.rows


def speed_up(config: Path, trials: int, repeats: int) -> None:
    seeds = range(trials)
    best = {1: float("inf"), 2: float("inf")}
    for _ in range(repeats):
        for workers in (1, 2):
            wall, _ = timed_sweep(config, seeds, workers=workers)
            best[workers] = min(best[workers], wall)
            print(f"  {workers} worker(s): {wall:.1f} s for {trials} trials ({trials / wall:.3f} trials/s)")
    print(f"speed-up, {config.name}, {trials} trials: 1 worker {trials / best[1]:.3f} trials/s, 2 workers "
          f"{trials / best[2]:.3f} trials/s -> {best[1] / best[2]:.2f}x   (target on 2 idle cores >= 1.8)  [{load()}]")


def ray_overhead(config: Path, trials: int, repeats: int) -> None:
    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        seeds = range(trials)
        timed_sweep(config, range(trials, trials + 2), backend="ray")  # warm Ray's worker processes once
        best = {"local": float("inf"), "ray": float("inf")}
        for _ in range(repeats):
            for backend in ("local", "ray"):
                wall, rows = timed_sweep(config, seeds, backend=backend, workers=2)
                best[backend] = min(best[backend], wall)
                inside = sum(r["wall_time"] for r in rows) / len(rows)
                print(f"  {backend}: {wall / trials:.3f} s per trial ({inside:.3f} s inside the worker)")
        print(f"Ray vs local pool, {config.name}, {trials} trials on 2 CPUs: {best['ray'] / trials:.3f} vs "
              f"{best['local'] / trials:.3f} s per trial -> ratio {best['ray'] / best['local']:.3f}   "
              f"(target <= 1.05)  [{load()}]")
    finally:
        ray.shutdown()


def memory(config: Path, trials: int, max_time: float | None) -> None:
    fixed = {"world.max_time": max_time} if max_time else None
    _, rows = timed_sweep(config, range(trials), fixed, workers=1, max_tasks_per_child=trials + 1, after=rss_mb)
    pids = {r["figures"]["pid"] for r in rows}
    rss = [r["figures"]["rss_mb"] for r in rows]
    warm = min(10, len(rss) - 1)
    what = f"{config.name}" + (f" cut at {max_time:g} sim s" if max_time else "")
    print(f"memory, one worker (pids {sorted(pids)}), {trials} trials of {what}: RSS after trial 1 "
          f"{rss[0]:.1f} MB, after trial {warm + 1} {rss[warm]:.1f} MB, after trial {trials} {rss[-1]:.1f} MB, "
          f"peak {max(rss):.1f} MB -> growth {rss[-1] - rss[warm]:.1f} MB after warm-up "
          f"({(rss[-1] - rss[warm]) / max(1, trials - warm - 1) * 1024:.0f} kB per trial)   (target < 50 MB)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=12, help="sort trials per timed sweep")
    parser.add_argument("--repeats", type=int, default=2, help="alternated repeats (best kept)")
    parser.add_argument("--config", type=Path, default=SORT)
    parser.add_argument("--skip-speed", action="store_true")
    parser.add_argument("--skip-ray", action="store_true")
    parser.add_argument("--memory-trials", type=int, default=0, help="trials for the memory figure (0: skip)")
    parser.add_argument("--memory-config", type=Path, default=PICK)
    parser.add_argument("--memory-max-time", type=float, metavar="S",
                        help="cut each memory trial at S sim seconds (the full scene is still built and torn down)")
    args = parser.parse_args(argv)
    print(f"[{load()}]")
    if not args.skip_speed:
        speed_up(args.config, args.trials, args.repeats)
    if not args.skip_ray:
        ray_overhead(args.config, args.trials, args.repeats)
    if args.memory_trials > 0:
        memory(args.memory_config, args.memory_trials, args.memory_max_time)
    return 0


if __name__ == "__main__":
    sys.exit(main())
