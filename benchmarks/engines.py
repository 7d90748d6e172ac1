"""The course's jobs on both engines, interleaved: the main job (``configs/sort_robot.toml``) and the patrol
(``configs/patrol_robot.toml``) per seed on PyBullet then MuJoCo, in this one process, and a Gymnasium env's steps.

    python benchmarks/engines.py --trials 20

Per job and engine it prints: the success rate (the run's outcome, which the world's goal check decides), the
median sim seconds per object (a run's sim time over its objects), the loop's wall seconds per sim second, and
start-up (building the Simulation from a loaded config: the engine's scene, plugins set up). Then the
``configs/gym/reach.toml`` env's steps per second on each engine (random actions, resets when an episode ends).
The engines run the same seeds one after the other, so a host whose speed drifts treats them alike; the two do not
simulate alike (see docs/engines.md), so the figures compare jobs, not steps.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
JOBS = {"sort": ROOT / "configs" / "sort_robot.toml", "patrol": ROOT / "configs" / "patrol_robot.toml"}
ENGINES = ("pybullet", "mujoco")


def objects(job: str, result: dict[str, Any]) -> int:
    """How many objects a run handled (sorted cubes, collected cans)."""
    if job == "sort":
        return sum(int(v) for k, v in result.items() if k.endswith("_sorted") and isinstance(v, int))
    return int(result.get("objects_collected", 0) or 0)


def trial(plugins: Any, job: str, engine: str, seed: int) -> dict[str, float]:
    """One run: outcome, sim time, objects, wall time of the loop and of the build."""
    from robokit.config import load_config
    from robokit.core.simulation import Simulation

    cfg = load_config(JOBS[job], plugins, {"world.engine": engine, "world.seed": seed})
    t0 = time.perf_counter()
    sim = Simulation(cfg, plugins)
    t1 = time.perf_counter()
    try:
        out = sim.run()
    finally:
        sim.close()
    wall = time.perf_counter() - t1
    return {"ok": float(out.outcome == "succeeded"), "sim": out.sim_time, "objects": objects(job, out.result),
            "loop_per_sim_s": wall / max(out.sim_time, 1e-9), "startup": t1 - t0}


def gym_steps_per_second(engine: str, steps: int) -> float:
    """Random-action steps per wall second of the reach env."""
    import robokit.gym

    env = robokit.gym.make(ROOT / "configs" / "gym" / "reach.toml", world__engine=engine)
    try:
        env.reset(seed=0)
        env.action_space.seed(0)
        t0 = time.perf_counter()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if terminated or truncated:
                env.reset()
        return steps / (time.perf_counter() - t0)
    finally:
        env.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--start-seed", type=int, default=0)
    parser.add_argument("--gym-steps", type=int, default=2000)
    args = parser.parse_args(argv)
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    rows: dict[tuple[str, str], list[dict[str, float]]] = {(j, e): [] for j in JOBS for e in ENGINES}
    for seed in range(args.start_seed, args.start_seed + args.trials):
        for job in JOBS:
            for engine in ENGINES:
                rows[(job, engine)].append(trial(plugins, job, engine, seed))
    print(f"{'job':8} {'engine':9} {'success':>9} {'sim s/object':>13} {'loop wall/sim s':>16} {'start-up s':>11}")
    for (job, engine), runs in rows.items():
        per_object = [r["sim"] / r["objects"] for r in runs if r["objects"]]
        print(f"{job:8} {engine:9} {sum(r['ok'] for r in runs):>4.0f}/{len(runs):<4} "
              f"{statistics.median(per_object) if per_object else float('nan'):>13.2f} "
              f"{statistics.median(r['loop_per_sim_s'] for r in runs):>16.4f} "
              f"{statistics.median(r['startup'] for r in runs):>11.3f}")
    for engine in ENGINES:
        print(f"gym reach {engine:9} {gym_steps_per_second(engine, args.gym_steps):10.0f} steps/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
