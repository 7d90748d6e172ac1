"""Sorting benchmark: N seeds of ``configs/sort_robot.toml`` (random cube positions and yaws).

Prints the share of objects sorted correctly (checked against the world at the end: every cube inside the bin of
its colour), the median and p95 sim seconds per object including perception (a run's ``total_time`` divided by
its number of objects), camera frames rendered per run, detection error, and the wall-clock real-time factor.

    python benchmarks/sort.py --trials 100
    python benchmarks/sort.py --trials 100 --processes 2

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

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "sort_robot.toml"


def in_bin(sim: Any, body: str, bin_name: str) -> bool:
    """True if the body's centre is over the bin's footprint and below its rim (ground truth, end of run)."""
    (x, y, z), _ = sim.world.pose(body)
    lo, hi = sim.world.body_aabb(bin_name)
    return lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1] and z < hi[2]


def measure(sim: Any, result: Any) -> dict[str, Any]:
    """After a trial, before its world closes: objects in the right bin (ground truth), detection errors."""
    spec = sim.config.behaviour
    assert spec is not None and spec.type == "sort", "the benchmark needs a config with a sort behaviour"
    bins = {colour: b.body for colour, b in spec.params.bins.items()}
    objects = [(n, c) for n in sim.world.body_names for c in bins
               if (n == c or n.startswith(f"{c}_")) and n != bins[c]]
    correct = sum(in_bin(sim, name, bins[colour]) for name, colour in objects)
    errors = [o["detection_error"] for o in result.result.get("objects", []) if o.get("detection_error") is not None]
    return {"objects": len(objects), "correct": correct, "detection_errors": errors}


def trials(seeds: range, config: str = str(CONFIG), workers: int = 1) -> list[dict[str, Any]]:
    """Run the seeds through the sweep engine (a spawn pool, one World per trial); one figure dict per seed."""
    from robokit.sweep import SweepOptions, SweepSpec, run_sweep

    run = run_sweep(SweepSpec(Path(config), seeds), SweepOptions(workers=workers, after=measure))
    return [{
        "seed": r["seed"], "outcome": r["outcome"], "reason": r["reason"], "objects": r["figures"].get("objects", 0),
        "correct": r["figures"].get("correct", 0), "total_time": r["figures"].get("total_time", 0.0),
        "frames": r["figures"].get("camera_frames"), "failures": r["figures"].get("failures", 0),
        "detection_errors": r["figures"].get("detection_errors", []), "sim": r["sim_time"] or 0.0,
        "wall": r["wall_time"],
    } for r in run.rows]


def percentile(values: list[float], q: float) -> float:
    """Nearest-rank percentile (q in 0..100)."""
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, round(q / 100.0 * len(ordered) + 0.5) - 1))
    return ordered[k]


def report(rows: list[dict[str, Any]], wall: float, processes: int) -> None:
    """Print the figures."""
    objects = sum(r["objects"] for r in rows)
    correct = sum(r["correct"] for r in rows)
    per_object = [r["total_time"] / r["objects"] for r in rows if r["objects"]]
    frames = [r["frames"] for r in rows if r["frames"] is not None]
    errors = [e for r in rows for e in r["detection_errors"]]
    sim_total = sum(r["sim"] for r in rows)
    print(f"trials: {len(rows)} (seeds {rows[0]['seed']}..{rows[-1]['seed']}, {processes} process(es))")
    print(f"objects sorted correctly: {correct}/{objects} = {100.0 * correct / max(1, objects):.2f} %  "
          f"(runs succeeded: {sum(r['outcome'] == 'succeeded' for r in rows)}/{len(rows)}, "
          f"failed pick attempts: {sum(r['failures'] for r in rows)})")
    print(f"sim seconds per object incl. perception: median {statistics.median(per_object):.3f}, "
          f"p95 {percentile(per_object, 95):.3f}, max {max(per_object):.3f}")
    print(f"camera frames per run: median {statistics.median(frames):g}, max {max(frames)}")
    if errors:
        print(f"detection error: median {1000 * statistics.median(errors):.2f} mm, "
              f"p95 {1000 * percentile(errors, 95):.2f} mm, max {1000 * max(errors):.2f} mm")
    print(f"wall: {wall:.1f} s for {sim_total:.1f} sim s -> real-time factor {sim_total / wall:.1f}x "
          f"({sim_total / wall / processes:.1f}x per process); median wall per run "
          f"{statistics.median(r['wall'] for r in rows):.2f} s")
    for r in rows:
        if r["outcome"] != "succeeded" or r["correct"] != r["objects"]:
            print(f"  seed {r['seed']}: {r['outcome']}, {r['correct']}/{r['objects']} sorted: {r['reason']}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--start-seed", type=int, default=0)
    parser.add_argument("--processes", type=int, default=1)
    parser.add_argument("--config", default=str(CONFIG))
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    rows = trials(range(args.start_seed, args.start_seed + args.trials), args.config, args.processes)
    report(rows, time.perf_counter() - t0, args.processes)
    return 0 if all(r["correct"] == r["objects"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
