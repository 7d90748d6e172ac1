"""Arm motion planning against straight lines, on seeded pick-and-place scenes with obstacles between cube and bin.

    python benchmarks/arm_planning.py --seeds 5
    python benchmarks/arm_planning.py --kinds wall,boxes --seeds 10 --engine mujoco

Each scene is configs/pick_obstacle.toml's table, Panda, cube and bin with the cube and the bin placed by the seed
and, between them, by kind:

- ``wall``: one thin wall, 0.15-0.3 m long, 0.2-0.3 m tall;
- ``shelf``: a shelf unit (a back panel and a top board overhanging it by 4 cm on both sides), 0.18-0.25 m tall;
- ``boxes``: two or three boxes, 6-10 cm wide, 0.14-0.25 m tall, in the middle fifth of the way from cube to bin;

The obstacles stand clear of the cube and of the bin (the arm's vertical moves over them stay straight).
- ``gap``: two boxes 6-8 cm tall on both sides of the cube (along y), leaving 8-9.5 cm between them: a hand
  whose fingers open across the gap meets a box on the way down, one turned a quarter turn fits;
- ``low_shelf``: a board 16-20 cm above the table over the bin's far half (on two posts beyond the bin).
- ``open``: nothing (what the planner costs where the straight way is clear).
- ``intruder``: the ``wall`` scene, and 0.3 s into the transport (the cube in the hand, the arm on its way over the
  wall) a board 3 cm thick, 10 cm deep and 4 cm longer than the wall is put 2-4 cm above the wall's top: a body that
  came after the plan. Its modes: ``rrt`` (nothing rechecked), ``rrt-stop`` (``recheck_hz = 10``, ``replans = 0``:
  the job stops) and ``rrt-replan`` (``recheck_hz = 10``, ``replans = 2``: planned again round the board).

Every scene runs ``pick_place`` headless with ``planner = "straight"``, ``planner = "rrt"`` with
``check_descents = false`` (``rrt-unchecked``: the straight moves down and up at the cube and bin checked for the
links up to the wrist only) and ``planner = "rrt"``, and prints per kind:

- success: the cube rests in the bin at the end (its centre inside the bin's box, below the rim);
- collisions: runs in which the arm or the cube touched an obstacle (contacts read every tick);
- refused: runs the behaviour failed at once with no collision-free way, or stopped when a body came into the
  planned way (one line naming what is in the way);
- joint path: the arm's joint travel over the run (sum over ticks of the Euclidean joint step, rad), median over
  the successful runs, and its ratio to the travel of straight lines on the same scene with its obstacles taken
  away (what the job costs with nothing in the way), median;
- plan ms: process time per free move (approach, transport) to decide the command: the arm solving the straight
  path and, with the planner, checking it and searching when it is blocked; mean;
- searched: free moves where the straight way was blocked and RRT-Connect ran (``intruder``: and the replans made,
  and the runs in which the board was put in the way: a run that failed before its transport never saw it);
- CPU ms / sim s: process time of the whole run per simulated second, median.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
BASE = ROOT / "configs" / "pick_obstacle.toml"
KINDS = ("wall", "shelf", "boxes", "gap", "low_shelf", "open", "intruder")
MODES = ("straight", "rrt-unchecked", "rrt")
INTRUDER_MODES = {"rrt": None, "rrt-stop": {"recheck_hz": 10.0, "replans": 0},
                  "rrt-replan": {"recheck_hz": 10.0, "replans": 2}}
FAR = [3.0, 3.0, 0.015]  # where the intruder waits until it is put in the way


def _box(size: list[float], position: list[float]) -> dict[str, Any]:
    return {"shape": "box", "size": size, "mass": 0, "position": position, "rgba": [0.6, 0.6, 0.65, 1]}


def scene(kind: str, seed: int) -> dict[str, Any]:
    """The config of one scene (a dict as the TOML would parse it)."""
    cfg = tomllib.loads(BASE.read_text(encoding="utf-8"))
    rng = np.random.default_rng([seed, KINDS.index(kind)])
    cx, cy = rng.uniform(0.42, 0.6), rng.uniform(0.22, 0.3)
    bx, by = rng.uniform(0.42, 0.58), rng.uniform(-0.32, -0.26)
    bodies = cfg["bodies"]
    del bodies["wall"]
    bodies["cube"]["position"] = [cx, cy, 0.025]
    bodies["cube"]["rpy_deg"] = [0, 0, float(rng.uniform(-30, 30))]
    bodies["bin"]["position"] = [bx, by, 0]
    cfg["behaviour"]["place_position"] = [bx, by, 0.03]
    mx, my = (cx + bx) / 2, (cy + by) / 2
    if kind in ("wall", "intruder"):
        length, height = rng.uniform(0.15, 0.3), rng.uniform(0.2, 0.3)
        bodies["obstacle_0"] = _box([length, 0.04, height], [mx, my, height / 2])
        if kind == "intruder":
            bodies["obstacle_1"] = _box([length + 0.04, 0.1, 0.03], FAR)
            cfg["intruder_at"] = [mx, my, height + float(rng.uniform(0.02, 0.04)) + 0.015]
    elif kind == "shelf":
        height, length = rng.uniform(0.18, 0.25), rng.uniform(0.2, 0.3)
        bodies["obstacle_0"] = _box([length, 0.02, height], [mx, my, height / 2])
        bodies["obstacle_1"] = _box([length, 0.1, 0.02], [mx, my, height + 0.01])
    elif kind == "boxes":
        n = int(rng.integers(2, 4))
        for i, f in enumerate(np.linspace(0.4, 0.6, n) if n > 1 else [0.5]):
            side, height = rng.uniform(0.06, 0.1), rng.uniform(0.14, 0.25)
            x, y = cx + f * (bx - cx) + rng.uniform(-0.08, 0.08), cy + f * (by - cy)
            bodies[f"obstacle_{i}"] = _box([side, side, height], [x, y, height / 2])
    elif kind == "gap":
        height, gap = rng.uniform(0.06, 0.08), rng.uniform(0.08, 0.095)
        bodies["cube"]["rpy_deg"] = [0, 0, float(rng.uniform(-10, 10))]
        for i, side in enumerate((-1, 1)):
            bodies[f"obstacle_{i}"] = _box([0.12, 0.06, height], [cx, cy + side * (gap / 2 + 0.03), height / 2])
    elif kind == "low_shelf":
        height = rng.uniform(0.16, 0.2)
        bodies["obstacle_0"] = _box([0.34, 0.14, 0.02], [bx, by - 0.08, height + 0.01])
        for i, side in enumerate((-1, 1)):
            bodies[f"obstacle_{i + 1}"] = _box([0.02, 0.02, height], [bx + side * 0.19, by - 0.13, height / 2])
    cfg["world"]["max_time"] = 20.0
    return cfg


class Timed:
    """Process time spent in methods of objects (each counted while ``when()`` holds), and the calls of the first."""

    def __init__(self) -> None:
        self.seconds, self.calls = 0.0, 0

    def wrap(self, owner: Any, name: str, *, count: bool, when: Any = lambda: True) -> None:
        inner = getattr(owner, name)

        def timed(*args: Any, **kwargs: Any) -> Any:
            if not when():
                return inner(*args, **kwargs)
            t0 = time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.process_time() - t0
                self.calls += count

        setattr(owner, name, timed)


def trial(kind: str, seed: int, mode: str, engine: str, *, bare: bool = False) -> dict[str, Any]:
    """One run; its figures. ``bare``: the scene with its obstacles taken away."""
    cfg = scene(kind, seed)
    intruder_at = cfg.pop("intruder_at", None)
    if bare:
        cfg["bodies"] = {k: v for k, v in cfg["bodies"].items() if not k.startswith("obstacle_")}
        intruder_at = None
    cfg["behaviour"]["planner"] = "rrt" if mode.startswith("rrt") else mode
    if mode == "rrt-unchecked":
        cfg["behaviour"]["planning"] = {"check_descents": False}
    if INTRUDER_MODES.get(mode):
        cfg["behaviour"]["planning"] = INTRUDER_MODES[mode]
    cfg["world"]["engine"] = engine
    cpu0 = time.process_time()
    with make_sim(cfg, base_dir=BASE.parent) as sim:
        w, pp = sim.world, sim.behaviour
        arm = pp.ctx.components["arm"]
        robot, cube = w.body("panda"), w.body("cube")
        obstacles = {w.body(n) for n in w.body_names if n.startswith("obstacle_")}
        decide = Timed()  # the behaviour choosing the command, then the arm solving it (IK along the path)
        decide.wrap(pp, "_free_move", count=True)
        decide.wrap(arm, "command", count=False, when=lambda: pp.state_name in ("APPROACH", "TRANSPORT"))
        joints = [j.index for j in arm.arm]
        last = np.array([s[0] for s in w.joint_states(robot, joints)])
        figures = {"travel": 0.0, "touched": False}

        def watch(s: Any) -> bool:
            nonlocal last, intruder_at
            if intruder_at is not None and pp.state_name == "TRANSPORT" and pp.time_in_state > 0.3:
                w.set_pose("obstacle_1", intruder_at)
                intruder_at = None
            q = np.array([st[0] for st in w.joint_states(robot, joints)])
            figures["travel"] += float(np.linalg.norm(q - last))
            last = q
            if not figures["touched"]:
                figures["touched"] = any(c.other in obstacles for who in (robot, cube) for c in w.contacts(who))
            return s.behaviour.outcome is not None

        sim.run_until(watch, int(20.0 / w.time_step))
        (x, y, z), _ = w.pose("cube")
        lo, hi = w.body_aabb("bin")
        placed = lo[0] < x < hi[0] and lo[1] < y < hi[1] and z < hi[2]
        stats = pp.moves.stats.as_dict() if pp.moves is not None else {}
        moved = intruder_at is None
        sim_time = w.time
        failed = pp.outcome is not None and pp.outcome.status == "failed"
        refused = failed and any("no collision-free way" in f for f in pp.failures)
    return {"ok": placed, "refused": refused or "came into the planned way" in (pp.outcome.reason if failed else ""),
            "touched": figures["touched"], "travel": figures["travel"], "moved": moved,
            "replans": stats.get("replans", 0),
            "plan_ms": 1000.0 * decide.seconds / max(decide.calls, 1), "searched": stats.get("planned", 0),
            "cpu": (time.process_time() - cpu0) / max(sim_time, 1e-9)}


def replanned(rows: list[dict[str, Any]]) -> str:
    """The intruder kind's extra figures: replans made, and runs in which the board was put in the way."""
    return f" ({sum(r['replans'] for r in rows)} replans; board put in {sum(r['moved'] for r in rows)} runs)"


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--kinds", default=",".join(KINDS))
    parser.add_argument("--engine", default="pybullet")
    args = parser.parse_args(argv)
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        print(f"unknown kind {unknown[0]!r}; kinds: {', '.join(KINDS)}", file=sys.stderr)
        return 2
    print("| scene | planner | success | collisions | refused | joint path (rad) | vs no obstacle | plan ms | "
          "searched | CPU ms / sim s |\n|---|---|---|---|---|---|---|---|---|---|")
    for kind in kinds:
        modes = tuple(INTRUDER_MODES) if kind == "intruder" else MODES
        runs = {mode: [trial(kind, seed, mode, args.engine) for seed in range(args.seeds)] for mode in modes}
        bare = [trial(kind, seed, "straight", args.engine, bare=True) for seed in range(args.seeds)]
        for mode in modes:
            rows = runs[mode]
            ratios = [r["travel"] / b["travel"] for r, b in zip(rows, bare, strict=True) if r["ok"] and b["ok"]]
            print(f"| {kind} | {mode} | {sum(r['ok'] for r in rows)}/{len(rows)} | "
                  f"{sum(r['touched'] for r in rows)} | {sum(r['refused'] for r in rows)} | "
                  f"{_median([r['travel'] for r in rows if r['ok']])} | "
                  f"{_median(ratios) + 'x' if ratios else '-'} | "
                  f"{statistics.mean(r['plan_ms'] for r in rows):.1f} | {sum(r['searched'] for r in rows)}"
                  f"{replanned(rows) if kind == 'intruder' else ''} | "
                  f"{statistics.median(r['cpu'] for r in rows) * 1000:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
