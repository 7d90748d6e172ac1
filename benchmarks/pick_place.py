"""Pick-and-place benchmark: N seeds of ``configs/pick_place.toml`` (random cube position and yaw).

Prints the success rate, the median and p95 sim seconds per pick-and-place (successful trials), the attempts
used, and the wall-clock real-time factor (sim seconds per wall second): per simulation in its run loop, and
overall (all processes, scene builds included).

    python benchmarks/pick_place.py --trials 200            # sequential, one process
    python benchmarks/pick_place.py --trials 200 --processes 2
    python benchmarks/pick_place.py --trials 50 --knock     # each trial: cube knocked out mid-transport once

Every trial is a pure function of (config, seed) run through the sweep engine (``robokit.sweep``): a World is built
inside the worker, nothing pybullet-owned is pickled. ``--processes 1`` is one worker process.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"


def knock_off(sim: Any, seed: int) -> None:
    """Run until the cube is in transport, then knock it out of the fingers onto a random spot on the table."""
    import numpy as np

    sim.run_until(lambda s: s.behaviour.state_name == "TRANSPORT" or s.outcome is not None, 4000)
    sim.step(20)
    x, y = np.random.default_rng(seed + 10_000).uniform((0.35, -0.2), (0.65, 0.3))
    sim.world.set_pose("cube", (float(x), float(y), 0.03))


def trials(seeds: range, config: str = str(CONFIG), knock: bool = False, workers: int = 1) -> list[dict[str, Any]]:
    """Run the seeds through the sweep engine; per seed: outcome, sim seconds, attempts, wall seconds (the run
    loop's, and the whole trial's with the scene build).

    With ``knock``, the cube is knocked out of the fingers once mid-transport (the retry path).
    """
    from robokit.sweep import SweepOptions, SweepSpec, run_sweep

    run = run_sweep(SweepSpec(Path(config), seeds), SweepOptions(workers=workers, before=knock_off if knock else None))
    return [{
        "seed": r["seed"], "outcome": r["outcome"], "reason": r["reason"],
        "pick_seconds": r["figures"].get("sim_time"), "attempts": r["figures"].get("attempts"),
        "placement_error": r["figures"].get("placement_error"), "run_sim_seconds": r["sim_time"] or 0.0,
        "run_wall": r["run_wall_time"], "wall": r["wall_time"],
    } for r in run.rows]


def percentile(values: list[float], q: float) -> float:
    """Nearest-rank percentile (q in 0..100)."""
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, round(q / 100.0 * len(ordered) + 0.5) - 1))
    return ordered[k]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=50)
    parser.add_argument("--start-seed", type=int, default=0)
    parser.add_argument("--processes", type=int, default=1)
    parser.add_argument("--config", default=str(CONFIG))
    parser.add_argument("--knock", action="store_true", help="knock the cube out of the fingers once per trial")
    args = parser.parse_args(argv)
    seeds = range(args.start_seed, args.start_seed + args.trials)
    t0 = time.perf_counter()
    rows = trials(seeds, args.config, args.knock, args.processes)
    wall = time.perf_counter() - t0
    ok = [r for r in rows if r["outcome"] == "succeeded"]
    times = [r["pick_seconds"] for r in ok]
    sim_total = sum(r["run_sim_seconds"] for r in rows)
    print(f"trials: {len(rows)} (seeds {seeds[0]}..{seeds[-1]}, {args.processes} process(es))")
    print(f"success: {len(ok)}/{len(rows)} = {100.0 * len(ok) / len(rows):.1f} %")
    if times:
        print(f"sim seconds per pick-and-place: median {statistics.median(times):.3f}, "
              f"p95 {percentile(times, 95):.3f}, max {max(times):.3f}")
        retried = sum(1 for r in ok if r["attempts"] > 1)
        errs = [r["placement_error"] for r in ok if r["placement_error"] is not None]
        if errs:
            print(f"placement error: median {1000 * statistics.median(errs):.1f} mm, max {1000 * max(errs):.1f} mm")
        print(f"succeeded after a retry: {retried}")
    loop_wall = sum(r["run_wall"] for r in rows)
    print(f"real-time factor: {sim_total / loop_wall:.1f}x per simulation (run loop), "
          f"{sim_total / wall:.1f}x overall ({sim_total:.1f} sim s in {wall:.1f} s wall, scene builds included)")
    for r in rows:
        if r["outcome"] != "succeeded":
            print(f"  seed {r['seed']}: {r['outcome']}: {r['reason']}")
    return 0 if len(ok) == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
