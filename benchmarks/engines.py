"""The course's jobs on both engines, interleaved: the main job (``configs/sort_robot.toml``) and the patrol
(``configs/patrol_robot.toml``) per seed on PyBullet then MuJoCo, in this one process, and a Gymnasium env's steps.

    python benchmarks/engines.py --trials 20
    python benchmarks/engines.py --grasp --trials 20 --start-seed 200
    python benchmarks/engines.py --loop            # needs valgrind: instructions per sim second of the main job

``--loop`` counts instructions (valgrind's callgrind: the figure a shared, loaded machine does not change) of the
main job's loop per simulated second, three ways: robokit on MuJoCo, the same compiled MuJoCo model stepped bare
(``mj_step`` alone, the model robokit built, from its state after set-up), and robokit on PyBullet. Only the loop
is counted: after set-up and the first tick (the first camera frame), ticks 1 to 421 (the sort approaches, grasps
and carries its first cube, before its second frame) run inside a call that callgrind is told to count
(``--toggle-collect``: CPython's ``functools_reduce`` calling back into Python once, a C frame nothing else in the
loop enters).

``--grasp`` measures held objects instead, per engine and seed: ``configs/pick_place.toml`` and a three-colour sort
(``configs/sort_robot.toml`` with a green bin and two green cubes added). While a cube is off the table (its centre
2 cm above its resting height) its position in the hand's frame is read every 4 ticks; a transport's slip is how far
it moved from where it was once the grip settled (40 ticks after lift-off). It prints the median and largest slip,
the pick-and-place's placement error (median, largest) and each job's successes.

Per job and engine it prints: the success rate (the run's outcome, which the world's goal check decides), the
median sim seconds per object (a run's sim time over its objects), the loop's wall seconds per sim second, and
start-up (building the Simulation from a loaded config: the engine's scene, plugins set up). Then the
``configs/gym/reach.toml`` env's steps per second on each engine (random actions, resets when an episode ends).
The engines run the same seeds one after the other, so a host whose speed drifts treats them alike; the two do not
simulate alike (see docs/engines.md), so the figures compare jobs, not steps.
"""

from __future__ import annotations

import argparse
import math
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


def three_colour_sort() -> dict[str, Any]:
    """``configs/sort_robot.toml`` as TOML parses it, with a green bin beside the red one and two green cubes."""
    from robokit.config import read_toml

    raw = read_toml(JOBS["sort"])
    raw["world"]["max_time"] = 60.0
    raw["bodies"]["green_bin"] = {**raw["bodies"]["red_bin"], "position": [0.05, 0.5, 0]}
    raw["bodies"]["green"] = {**raw["bodies"]["red"], "rgba": [0.1, 0.8, 0.2, 1]}
    raw["regions"]["table"]["min_spacing"] = 0.09
    raw["sensors"]["truth"]["bodies"] += ["green_0", "green_1"]
    raw["behaviour"]["bins"]["green"] = {"body": "green_bin"}
    return raw


def held_slips(sim: Any) -> list[float]:
    """Run ``sim`` to its end; the slip (m) of each transport of a cube in the Panda's hand (see the module doc)."""
    world = sim.world
    hand = {j.child_link: j.index for j in world.joints("panda")}["panda_hand"]
    cubes = [n for n in world.body_names if n.startswith(("red_", "blue_", "green_", "cube"))]
    resting = {c: world.pose(c)[0][2] for c in cubes}
    watching: dict[str, list[Any]] = {}
    slips: list[float] = []
    step = world.step

    def watched() -> None:
        step()
        if world.tick % 4:
            return
        for cube in cubes:
            pose = world.pose(cube)
            if pose[0][2] > resting[cube] + 0.02:
                offset = world.multiply_transforms(*world.invert_transform(*world.pose("panda", hand)), *pose)[0]
                seen = watching.setdefault(cube, [])
                seen.append(offset)
            elif cube in watching:
                seen = watching.pop(cube)
                if len(seen) > 30:
                    slips.append(max(math.dist(seen[10], o) for o in seen[10:]))

    world.step = watched
    out = sim.run()
    return [float(out.outcome == "succeeded"), float(out.result.get("placement_error") or 0.0), *slips]


def grasp(trials: int, start: int) -> None:
    """``--grasp``: slip, placement error and success per engine (see the module doc)."""
    from robokit.config import build_config, load_config
    from robokit.core.simulation import Simulation
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    sort3 = three_colour_sort()
    print(f"{'job':14} {'engine':9} {'success':>8} {'slip median / max mm':>21} {'placement median / max mm':>26}")
    for job in ("pick_place", "sort 3 colours"):
        for engine in ENGINES:
            ok, places, slips = 0.0, [], []
            for seed in range(start, start + trials):
                overrides = {"world.engine": engine, "world.seed": seed}
                if job == "pick_place":
                    cfg = load_config(ROOT / "configs" / "pick_place.toml", plugins, overrides)
                else:
                    raw = {**sort3, "world": {**sort3["world"], "engine": engine, "seed": seed}}
                    cfg = build_config(raw, plugins, source="sort_robot.toml + green", base_dir=ROOT / "configs")
                with Simulation(cfg, plugins) as sim:
                    success, place, *held = held_slips(sim)
                ok += success
                places.append(place * 1000)
                slips += [s * 1000 for s in held]
            place_text = (f"{statistics.median(places):.2f} / {max(places):.2f}" if job == "pick_place" else "-")
            print(f"{job:14} {engine:9} {ok:>4.0f}/{trials:<3} "
                  f"{statistics.median(slips):>10.2f} / {max(slips):<8.2f} {place_text:>26}", flush=True)


def loop_only(how: str, ticks: int) -> None:
    """``--loop-only``: build the main job (seed 3), then run ``ticks`` ticks of its loop (``bare``: step its
    compiled MuJoCo model with ``mj_step`` instead, the motors' controls as set-up left them)."""
    from robokit.config import load_config
    from robokit.core.simulation import Simulation
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    cfg = load_config(JOBS["sort"], plugins, {"world.engine": "pybullet" if how == "pybullet" else "mujoco",
                                              "world.seed": 3})
    with Simulation(cfg, plugins) as sim:
        sim.step(1)
        if how == "bare":
            import mujoco

            model, data = sim.world.client.model, sim.world.client.data

            def loop() -> None:
                for _ in range(ticks):
                    mujoco.mj_step(model, data)
        else:
            def loop() -> None:
                sim.step(ticks)
        counted(loop)


def counted(run: Any) -> None:
    """Call ``run`` from inside ``functools.reduce`` (two items: one call), the C function (CPython's
    ``functools_reduce``) that ``valgrind --toggle-collect=functools_reduce`` counts within; nothing in the loop
    enters it (libc's ``qsort`` would not do: MuJoCo sorts inside a step)."""
    import functools

    functools.reduce(lambda _a, _b: run(), (None, None))


def loop_instructions(ticks: int) -> None:
    """``--loop``: instructions per sim second of each way, from two callgrind runs of ``--loop-only``."""
    import subprocess
    import sys
    import tempfile

    time_step = 1.0 / 240.0
    print(f"{'loop':18} {'instructions per sim s':>24} {'x bare MuJoCo':>14}")
    per_second = {}
    for how in ("bare", "mujoco", "pybullet"):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "callgrind.out"
            subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=functools_reduce",
                            f"--callgrind-out-file={out}", sys.executable, __file__, "--loop-only", how, "--ticks",
                            str(ticks)], check=True, capture_output=True)
            summary = [line for line in out.read_text().splitlines() if line.startswith(("summary:", "totals:"))]
            count = int(summary[0].split()[1])
        per_second[how] = count / (ticks * time_step)
        print(f"{how:18} {per_second[how]:>24,.0f} {per_second[how] / per_second['bare']:>14.2f}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--start-seed", type=int, default=0)
    parser.add_argument("--gym-steps", type=int, default=2000)
    parser.add_argument("--grasp", action="store_true", help="held objects' slip and placement instead")
    parser.add_argument("--loop", action="store_true", help="instructions per sim second (valgrind) instead")
    parser.add_argument("--loop-only", choices=("mujoco", "bare", "pybullet"), help=argparse.SUPPRESS)
    parser.add_argument("--ticks", type=int, default=240, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.loop_only:
        loop_only(args.loop_only, args.ticks)
        return 0
    if args.loop:
        loop_instructions(420)  # ticks 1 to 421: between the first two camera frames on both engines
        return 0
    if args.grasp:
        grasp(args.trials, args.start_seed)
        return 0
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
