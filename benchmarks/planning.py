"""Navigation planners against the clearance rules, on seeded scenes (``robokit.planning.scenes``).

    python benchmarks/planning.py --seeds 5
    python benchmarks/planning.py --kinds dead_end,narrow --seeds 10 --timeout 90
    python benchmarks/planning.py --pickup --seeds 20            # the collector that picks up (patrol_pickup.toml)

For every scene kind (open, clutter, narrow passage, dead end, room behind a door) and seed it runs
``go_to_goal`` headless with ``planner = "rules"`` (today's clearance rules), ``"astar"`` (occupancy grid from the
lidar, A*, dynamic window) and ``"astar"`` with ``planning.known_map`` (the grid seeded with the scene), and prints
side by side:

- success: the goal reached within the timeout (sim s);
- path / shortest: distance driven over the shortest collision-free way to within the goal's tolerance (A* on the
  true map at 2.5 cm cells for a disk of the robot's radius, shortened by line of sight, less the tolerance),
  median over the successful runs;
- time to goal: sim seconds, median over the successful runs;
- collisions: new contacts with a wall (the drive's contact list, read at every drive update), total;
- plan ms: process time per A* call (path shortening included), mean;
- CPU ms / sim s: process time of the whole run per simulated second (physics, lidar, behaviour), median.

With ``--pickup`` it runs ``configs/patrol_pickup.toml`` instead (the collectbot patrols, grips each can, carries it
into the bin), per seed and ``--modes`` (``rules``, ``astar``): success (the run's goal met), cans inside the bin's
area at the end (read from the world here, not from the behaviour), collisions, sim time and CPU per sim s.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from robokit.planning import GridConfig, OccupancyGrid
from robokit.planning.scenes import KINDS, Box, layout, scene
from robokit.planning.search import astar, path_length, shorten
from robokit.testing import make_sim

ROBOT_RADIUS = 0.19
"""The diffbot's footprint (0.30 x 0.22 m base, wheels out to 0.145 m) fits in a disk of this radius, m."""

MODES: dict[str, dict[str, Any]] = {
    "rules": {"planner": "rules"},
    "astar": {"planner": "astar"},
    "astar+map": {"planner": "astar", "planning": {"known_map": True}},
}


def shortest(boxes: list[Box], start: tuple[float, float], goal: tuple[float, float]) -> float:
    """Length of the shortest path a disk of ``ROBOT_RADIUS`` can take on the true map, m (inf: none)."""
    xs = [c for b in boxes for c in (b[0], b[2])]
    ys = [c for b in boxes for c in (b[1], b[3])]
    grid = OccupancyGrid((min(xs), min(ys)), (max(xs), max(ys)), GridConfig(resolution=0.025),
                         clearance_cap=ROBOT_RADIUS + 0.05)
    grid.mark_boxes(boxes)
    cells = astar(grid.clearance, grid.cell(*start), grid.cell(*goal), ROBOT_RADIUS, grid.res)
    if cells is None:
        return math.inf
    short = shorten(grid.clearance, cells, ROBOT_RADIUS)
    return path_length([start, *[grid.centre(*c) for c in short[1:-1]], goal])


def trial(kind: str, seed: int, mode: str, timeout: float) -> dict[str, Any]:
    """One run; its figures."""
    cfg, _ = scene(kind, seed, timeout=timeout)
    cfg["behaviour"].update(MODES[mode])
    touching: set[str] = set()
    collisions = 0
    t0 = time.process_time()
    with make_sim(cfg) as sim:
        while sim.outcome is None and sim.world.time < timeout + 1:
            sim.step(4)
            now = {n for n in sim.readings["drive"].contacts if n.startswith("wall_")}
            collisions += len(now - touching)
            touching = now
        cpu = time.process_time() - t0
        result = sim.behaviour.result()
        ok = sim.outcome is not None and sim.outcome.status == "succeeded"
        return {"ok": ok, "t": sim.world.time, "dist": sim.readings["drive"].distance, "collisions": collisions,
                "plan_ms": result.get("planning", {}).get("plan_ms_mean"), "plans": result.get("planning", {})
                .get("plans", 0), "cpu_per_s": 1e3 * cpu / max(sim.world.time, 1e-9)}


PICKUP = Path(__file__).resolve().parents[1] / "configs" / "patrol_pickup.toml"
BIN_AREA = ((0.7, 3.35), (1.3, 4.0))
"""The bin of patrol_pickup.toml (inside of the pen), world xy, m: written out here, not read from the config."""


def pickup_trial(seed: int, mode: str) -> dict[str, Any]:
    """One patrol_pickup run; where the cans are at the end is read from the world."""
    t0 = time.process_time()
    overrides = {f"behaviour.{k}": v for k, v in MODES[mode].items()}
    with make_sim(PICKUP, seed=seed, overrides=overrides) as sim:
        result = sim.run()
        world = sim.world
        cans = [n for n in world.body_names if n.startswith("can")]
        (x0, y0), (x1, y1) = BIN_AREA
        inside = sum(1 for n in cans if x0 < world.pose(n)[0][0] < x1 and y0 < world.pose(n)[0][1] < y1
                     and world.pose(n)[0][2] < 0.15)
    cpu = time.process_time() - t0
    return {"ok": result.outcome == "succeeded", "inside": inside, "cans": len(cans), "t": result.sim_time,
            "collisions": result.result.get("collisions", 0), "cpu_per_s": 1e3 * cpu / max(result.sim_time, 1e-9)}


def pickup(seeds: int, modes: list[str], start: int = 0) -> int:
    print(f"configs/patrol_pickup.toml, seeds {start}..{start + seeds - 1}\n")
    header = f"{'planner':10} {'success':>8} {'cans in bin':>12} {'collisions':>10} {'sim s':>7} {'CPU ms/sim s':>13}"
    print(header)
    print("-" * len(header))
    for mode in modes:
        runs = [pickup_trial(seed, mode) for seed in range(start, start + seeds)]
        failed = [start + s for s, r in enumerate(runs) if not r["ok"]]
        print(f"{mode:10} {sum(r['ok'] for r in runs):>4}/{len(runs):<3} "
              f"{sum(r['inside'] for r in runs):>6}/{sum(r['cans'] for r in runs):<5} "
              f"{sum(r['collisions'] for r in runs):>10} {median([r['t'] for r in runs]):>7} "
              f"{median([r['cpu_per_s'] for r in runs]):>13}" + (f"   failed seeds: {failed}" if failed else ""),
              flush=True)
    return 0


def median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds per scene kind (0..N-1)")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated, of {', '.join(KINDS)}")
    ap.add_argument("--modes", default=",".join(MODES), help=f"comma-separated, of {', '.join(MODES)}")
    ap.add_argument("--timeout", type=float, default=60.0, help="sim seconds allowed per run")
    ap.add_argument("--pickup", action="store_true", help="run configs/patrol_pickup.toml instead of the scenes")
    ap.add_argument("--start-seed", type=int, default=0, help="first seed (with --pickup)")
    args = ap.parse_args(argv)
    kinds = args.kinds.split(",")
    modes = args.modes.split(",")
    for name, known in (("kind", KINDS), ("mode", MODES)):
        bad = [k for k in (kinds if name == "kind" else modes) if k not in known]
        if bad:
            print(f"unknown {name} {bad[0]!r}; expected one of {', '.join(known)}", file=sys.stderr)
            return 2
    if args.pickup:
        return pickup(args.seeds, [m for m in modes if m in ("rules", "astar")], args.start_seed)
    print(f"{args.seeds} seeds per kind, timeout {args.timeout:g} sim s\n")
    header = (f"{'scene':9} {'planner':10} {'success':>8} {'path/shortest':>14} {'time to goal':>13} "
              f"{'collisions':>10} {'plan ms':>8} {'CPU ms/sim s':>13}")
    print(header)
    print("-" * len(header))
    for kind in kinds:
        best = {}
        for seed in range(args.seeds):
            boxes, start, goal = layout(kind, seed)
            best[seed] = shortest(boxes, start[:2], goal)
        for mode in modes:
            runs = [(seed, trial(kind, seed, mode, args.timeout)) for seed in range(args.seeds)]
            good = [(s, r) for s, r in runs if r["ok"]]
            tol = scene(kind, 0)[0]["behaviour"]["tolerance"]
            ratio = [r["dist"] / (best[s] - tol) for s, r in good if math.isfinite(best[s])]
            plan = [r["plan_ms"] for _, r in runs if r["plan_ms"] is not None]
            print(f"{kind:9} {mode:10} {len(good):>4}/{len(runs):<3} {median(ratio):>14} "
                  f"{median([r['t'] for _, r in good]):>13} {sum(r['collisions'] for _, r in runs):>10} "
                  f"{(f'{statistics.mean(plan):.1f}' if plan else '-'):>8} "
                  f"{median([r['cpu_per_s'] for _, r in runs]):>13}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
