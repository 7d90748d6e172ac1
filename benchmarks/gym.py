"""Environment steps per second: robokit's ``reach``, ``push`` and ``pick`` (configs/gym/) against panda-gym's
``PandaReach-v3``, ``PandaPush-v3`` and ``PandaPickAndPlace-v3``, side by side.

    pip install panda-gym          # benchmark only (not a robokit dependency; it pulls gymnasium and pybullet)
    python benchmarks/gym.py --steps 2000 --rounds 5               # speed, all three tasks
    python benchmarks/gym.py --tasks pick --steps 1000 --rounds 9   # one task
    python benchmarks/gym.py --random-episodes 300                 # start distance and random-policy success
    pip install gymnasium-robotics  # --engines only (not a robokit dependency); its Fetch envs run on MuJoCo
    python benchmarks/gym.py --engines --steps 1000 --rounds 3     # robokit on PyBullet and MuJoCo, and Fetch

Both environments are made through ``gymnasium.make`` (so both carry Gymnasium's default wrappers), step with
uniformly random actions from seeded generators, and reset when an episode ends. They run the same physics:
a 0.002 s physics step, 20 physics steps per env step (0.04 sim-s), 50-step episodes, the Panda on a table
(robokit's scene also holds a ground plane and a goal marker, as panda-gym's does). Within a round the
two alternate every ``--chunk`` steps so that machine load hits both alike; the ratio is taken per round and the
median reported.

``--engines`` compares robokit's two engines instead: each task's env made with ``engine="pybullet"`` and with
``engine="mujoco"``, interleaved the same way, with gymnasium-robotics' ``FetchReach-v4`` / ``FetchPush-v4`` /
``FetchPickAndPlace-v4`` (a MuJoCo Fetch arm: 0.002 s physics steps, 20 per env step, as here) as the anchor when
gymnasium-robotics is installed (1.4.2 needs one shim on MuJoCo 4.0: :func:`integer_joint_types`). It prints
steps per second per env and MuJoCo / PyBullet per round.

``--random-episodes N`` compares the tasks themselves instead: the median start distance (achieved to desired goal
at reset) and the success rate of uniformly random actions over N episodes, for each pair.
Resets are timed separately (mean of ``--resets`` resets each). Wall-clock figures depend on the machine: the
load average is printed with them.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


PAIRS = {"reach": ("Reach", "PandaReach-v3"), "push": ("Push", "PandaPush-v3"),
         "pick": ("Pick", "PandaPickAndPlace-v3")}


def make_robokit(task: str, goal_env: bool = False) -> Any:
    import gymnasium

    import robokit.gym  # noqa: F401 - registers robokit/Reach-v0 ...

    return gymnasium.make(f"robokit/{PAIRS[task][0]}-v0", goal_env=goal_env)


FETCH = {"reach": "FetchReach-v4", "push": "FetchPush-v4", "pick": "FetchPickAndPlace-v4"}


def make_engine(task: str, engine: str) -> Any:
    import gymnasium

    import robokit.gym  # noqa: F401 - registers robokit/Reach-v0 ...

    return gymnasium.make(f"robokit/{PAIRS[task][0]}-v0", engine=engine)


def integer_joint_types() -> None:
    """Let gymnasium-robotics' MuJoCo helpers read joint types on MuJoCo 4.0, whose enums compare unequal to a
    numpy integer on their left (``mjJNT_SLIDE == np.int32(2)`` is False, so its ``joint_type in (mjJNT_HINGE,
    mjJNT_SLIDE)`` fails an assertion): its helper module sees the joint types as plain ints. Nothing else of
    gymnasium-robotics changes."""
    import types

    import mujoco
    from gymnasium_robotics.utils import mujoco_utils

    class Mujoco(types.ModuleType):
        def __getattr__(self, name: str) -> Any:
            return getattr(mujoco, name)

    shim = Mujoco("mujoco")
    shim.mjtJoint = types.SimpleNamespace(**{n: int(getattr(mujoco.mjtJoint, n))  # type: ignore[attr-defined]
                                             for n in dir(mujoco.mjtJoint) if n.startswith("mjJNT_")})
    mujoco_utils.mujoco = shim


def make_fetch(task: str) -> Any | None:
    """gymnasium-robotics' Fetch env for ``task``, or None when gymnasium-robotics is not installed."""
    import gymnasium

    try:
        import gymnasium_robotics
    except ImportError:
        print(f"{FETCH[task]} left out: gymnasium-robotics is not installed (pip install gymnasium-robotics)")
        return None
    gymnasium.register_envs(gymnasium_robotics)
    integer_joint_types()
    try:
        env = gymnasium.make(FETCH[task])
        env.reset(seed=0)
    except Exception as exc:  # noqa: BLE001 - an anchor that does not run is left out, and said so
        print(f"{FETCH[task]} left out: it does not run here ({type(exc).__name__}: {str(exc) or 'an assertion'}; "
              f"gymnasium-robotics {gymnasium_robotics.__version__})")
        return None
    return env


def engines(task: str, args: argparse.Namespace) -> None:
    """``--engines``: interleaved env steps per second of robokit on each engine (and Fetch), side by side."""
    envs = {f"robokit {task} {engine}": make_engine(task, engine) for engine in ("pybullet", "mujoco")}
    fetch = make_fetch(task)
    if fetch is not None:
        envs[f"gymnasium-robotics {FETCH[task]}"] = fetch
    names = list(envs)
    rates: dict[str, list[float]] = {n: [] for n in names}
    ratios, anchors = [], []
    for r in range(args.rounds):
        runners = {n: Runner(envs[n], seed=r) for n in names}
        for _ in range(args.steps // args.chunk):
            for name in names:
                runners[name].run(args.chunk)
        for name in names:
            rates[name].append(runners[name].cpu_rate)
        ratios.append(runners[names[1]].cpu_rate / runners[names[0]].cpu_rate)
        if fetch is not None:
            anchors.append(runners[names[1]].cpu_rate / runners[names[2]].cpu_rate)
        print(f"round {r + 1}: " + "  ".join(f"{n} {rates[n][-1]:6.0f}" for n in names)
              + f" steps per CPU s; mujoco / pybullet {ratios[-1]:.2f}", flush=True)
    for name in names:
        print(f"{name:40s} median {statistics.median(rates[name]):6.0f} env steps per CPU second")
    print(f"{task}: robokit mujoco / pybullet by CPU time: median {statistics.median(ratios):.2f} "
          f"(min {min(ratios):.2f}, max {max(ratios):.2f})" + ("" if fetch is not None else
                                                               "; Fetch left out (see above)"))
    if anchors:
        print(f"{task}: robokit mujoco / {FETCH[task]} by CPU time: median {statistics.median(anchors):.2f}")
    for env in envs.values():
        env.close()


def make_panda_gym(task: str) -> Any:
    import gymnasium
    import panda_gym  # noqa: F401 - registers the Panda environments

    return gymnasium.make(PAIRS[task][1])


class Runner:
    """Steps one environment with seeded random actions, resetting when an episode ends; keeps its wall time."""

    def __init__(self, env: Any, seed: int) -> None:
        self.env, self.rng = env, np.random.default_rng(seed)
        self.low, self.high = env.action_space.low, env.action_space.high
        env.reset(seed=seed)
        self.seconds, self.cpu, self.steps, self.episodes = 0.0, 0.0, 0, 0

    def run(self, steps: int) -> None:
        acts = self.rng.uniform(self.low, self.high, (steps, *self.env.action_space.shape)).astype(np.float32)
        env = self.env
        t0, c0 = time.perf_counter(), time.process_time()
        for a in acts:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
                self.episodes += 1
        self.seconds += time.perf_counter() - t0
        self.cpu += time.process_time() - c0
        self.steps += steps

    @property
    def rate(self) -> float:
        return self.steps / self.seconds

    @property
    def cpu_rate(self) -> float:
        """Env steps per CPU second of this process (less sensitive to other processes' load than wall time)."""
        return self.steps / self.cpu


def reset_ms(env: Any, n: int) -> float:
    """Mean wall milliseconds of one ``reset`` (after a few steps, so there is state to undo)."""
    total = 0.0
    for i in range(n):
        env.reset(seed=i)
        for _ in range(3):
            env.step(env.action_space.sample())
        t0 = time.perf_counter()
        env.reset(seed=i)
        total += time.perf_counter() - t0
    return 1000.0 * total / n


def random_policy(env: Any, episodes: int, seed: int = 0) -> tuple[float, float]:
    """Median start distance (m) and success rate of uniformly random actions over ``episodes`` episodes."""
    rng = np.random.default_rng(seed)
    starts, successes = [], 0
    for i in range(episodes):
        obs, info = env.reset(seed=seed + i)
        starts.append(float(np.linalg.norm(obs["achieved_goal"] - obs["desired_goal"])))
        done = False
        while not done:
            action = rng.uniform(env.action_space.low, env.action_space.high).astype(np.float32)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        successes += bool(info["is_success"])
    return statistics.median(starts), successes / episodes


def compare_tasks(tasks: list[str], episodes: int) -> None:
    for task in tasks:
        for name, env in ((f"robokit {task}", make_robokit(task, goal_env=True)),
                          (f"panda-gym {PAIRS[task][1]}", make_panda_gym(task))):
            median, rate = random_policy(env, episodes)
            print(f"{name:34s} median start distance {median:.3f} m; random actions succeed in "
                  f"{100 * rate:.1f}% of {episodes} episodes")
            env.close()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="reach,push,pick", help="comma-separated: reach, push, pick")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--chunk", type=int, default=50, help="steps per turn when alternating")
    parser.add_argument("--resets", type=int, default=200)
    parser.add_argument("--random-episodes", type=int, default=0, help="compare the tasks instead (see above)")
    parser.add_argument("--engines", action="store_true", help="robokit on each engine, and Fetch (see above)")
    args = parser.parse_args(argv)
    tasks = [t for t in args.tasks.split(",") if t]
    if unknown := [t for t in tasks if t not in PAIRS]:
        print(f"gym benchmark: error: unknown task {unknown[0]!r}; tasks: {', '.join(PAIRS)}", file=sys.stderr)
        return 2
    try:
        if args.random_episodes:
            compare_tasks(tasks, args.random_episodes)
            return 0
        if args.engines:
            for task in tasks:
                engines(task, args)
            print(f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
            return 0
        for task in tasks:
            speed(task, args)
    except ImportError as exc:
        print(f"gym benchmark: error: {exc.name} is not installed (pip install panda-gym)", file=sys.stderr)
        return 2
    print(f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
    return 0


def speed(task: str, args: argparse.Namespace) -> None:
    """Interleaved env steps per second of one task pair, printed side by side."""
    envs = {f"robokit {task}": make_robokit(task), f"panda-gym {PAIRS[task][1]}": make_panda_gym(task)}
    names = list(envs)
    rates: dict[str, list[float]] = {n: [] for n in names}
    ratios, cpu_ratios = [], []
    for r in range(args.rounds):
        runners = {n: Runner(envs[n], seed=r) for n in names}
        for _ in range(args.steps // args.chunk):  # alternate in short chunks: load drift hits both alike
            for name in names:
                runners[name].run(args.chunk)
        for name in names:
            rates[name].append(runners[name].rate)
        ratios.append(rates[names[0]][-1] / rates[names[1]][-1])
        cpu_ratios.append(runners[names[0]].cpu_rate / runners[names[1]].cpu_rate)
        print(f"round {r + 1}: " + "  ".join(f"{n} {rates[n][-1]:7.0f} steps/s" for n in names)
              + f"  ratio {ratios[-1]:.2f} (CPU time {cpu_ratios[-1]:.2f})")
    for name in names:
        print(f"{name:34s} median {statistics.median(rates[name]):7.0f} env steps/s "
              f"(min {min(rates[name]):.0f}, max {max(rates[name]):.0f}); "
              f"reset {reset_ms(envs[name], args.resets):.3f} ms")
    print(f"{task}: ratio robokit / panda-gym: median {statistics.median(ratios):.2f} "
          f"(min {min(ratios):.2f}, max {max(ratios):.2f}) over {args.rounds} rounds of {args.steps} steps; "
          f"by CPU time {statistics.median(cpu_ratios):.2f} (min {min(cpu_ratios):.2f}, max {max(cpu_ratios):.2f})")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    sys.exit(main())
