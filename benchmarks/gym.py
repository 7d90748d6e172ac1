"""Environment steps per second: robokit's ``reach`` (configs/gym/reach.toml) against panda-gym's ``PandaReach-v3``.

    pip install panda-gym          # benchmark only (not a robokit dependency; it pulls gymnasium and pybullet)
    python benchmarks/gym.py --steps 2000 --rounds 5

Both environments are made through ``gymnasium.make`` (so both carry Gymnasium's default wrappers), step with
uniformly random actions from seeded generators, and reset when an episode ends. They run the same physics:
a 0.002 s physics step, 20 physics steps per env step (0.04 sim-s), 50-step episodes, the Panda alone on a table
(robokit's scene also holds a ground plane and a goal marker, as panda-gym's does). Within a round the
two alternate every ``--chunk`` steps so that machine load hits both alike; the ratio is taken per round and the
median reported.
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


def make_robokit() -> Any:
    import gymnasium

    import robokit.gym

    return gymnasium.make(robokit.gym.ENV_ID, config=str(ROOT / "configs" / "gym" / "reach.toml"))


def make_panda_gym() -> Any:
    import gymnasium
    import panda_gym  # noqa: F401 - registers the Panda environments

    return gymnasium.make("PandaReach-v3")


class Runner:
    """Steps one environment with seeded random actions, resetting when an episode ends; keeps its wall time."""

    def __init__(self, env: Any, seed: int) -> None:
        self.env, self.rng = env, np.random.default_rng(seed)
        self.low, self.high = env.action_space.low, env.action_space.high
        env.reset(seed=seed)
        self.seconds, self.steps, self.episodes = 0.0, 0, 0

    def run(self, steps: int) -> None:
        acts = self.rng.uniform(self.low, self.high, (steps, *self.env.action_space.shape)).astype(np.float32)
        env = self.env
        t0 = time.perf_counter()
        for a in acts:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                env.reset()
                self.episodes += 1
        self.seconds += time.perf_counter() - t0
        self.steps += steps

    @property
    def rate(self) -> float:
        return self.steps / self.seconds


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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--chunk", type=int, default=50, help="steps per turn when alternating")
    parser.add_argument("--resets", type=int, default=200)
    args = parser.parse_args(argv)
    try:
        envs = {"robokit reach": make_robokit(), "panda-gym PandaReach-v3": make_panda_gym()}
    except ImportError as exc:
        print(f"gym benchmark: error: {exc.name} is not installed (pip install panda-gym)", file=sys.stderr)
        return 2
    names = list(envs)
    rates: dict[str, list[float]] = {n: [] for n in names}
    ratios = []
    for r in range(args.rounds):
        runners = {n: Runner(envs[n], seed=r) for n in names}
        for _ in range(args.steps // args.chunk):  # alternate in short chunks: load drift hits both alike
            for name in names:
                runners[name].run(args.chunk)
        for name in names:
            rates[name].append(runners[name].rate)
        ratios.append(rates[names[0]][-1] / rates[names[1]][-1])
        print(f"round {r + 1}: " + "  ".join(f"{n} {rates[n][-1]:7.0f} steps/s" for n in names)
              + f"  ratio {ratios[-1]:.2f}")
    for name in names:
        print(f"{name:26s} median {statistics.median(rates[name]):7.0f} env steps/s "
              f"(min {min(rates[name]):.0f}, max {max(rates[name]):.0f}); "
              f"reset {reset_ms(envs[name], args.resets):.3f} ms")
    print(f"ratio robokit / panda-gym: median {statistics.median(ratios):.2f} "
          f"(min {min(ratios):.2f}, max {max(ratios):.2f}) over {args.rounds} rounds of {args.steps} steps")
    print(f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} cores")
    for env in envs.values():
        env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
