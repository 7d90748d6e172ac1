"""Learn ``reach`` with Augmented Random Search on a linear policy — numpy only, a few minutes on 2 cores.

ARS (Mania, Guy & Recht, 2018, "V2-t"): perturb the weights and bias of a linear policy in ``directions`` random
directions, run the same ``episodes`` with ``+noise`` and with ``-noise`` per direction (the same episode seeds for
every direction of an iteration, so directions are compared on equal terms), keep the ``top`` best, and step along
them, scaled by the spread of their returns. Observations are normalised by running mean and standard deviation.
Every episode is seeded from the run's generator, so a run is repeatable.

    python examples/rl/ars_reach.py                                   # the full run, writes the policy
    python examples/rl/ars_reach.py --iterations 10 --out /tmp/p.npz  # a short run
    robokit run configs/reach_policy.toml                             # watch the policy the full run wrote

The script prints one line per iteration (mean return, success rate of that iteration's rollouts) and the final
success rate over ``--eval-episodes`` fresh seeds.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "gym" / "reach.toml"
OUT = ROOT / "configs" / "policies" / "reach_linear.npz"
OBSERVATIONS = ("task.goal_delta",)
"""What the linear policy sees: the goal minus the end-effector position. A linear policy on panda-gym's full
observation (ee position and velocity, goal: 9 numbers, 30 weights) learns the same thing several times slower;
``--observations config`` uses the config's own list."""
EVAL_SEED = 1_000_000
VALIDATION_SEED = 2_000_000


class RunningStats:
    """Running mean and variance of observations (Welford), for normalisation."""

    def __init__(self, n: int) -> None:
        self.count, self.mean, self.m2 = 0, np.zeros(n), np.zeros(n)

    def push(self, x: np.ndarray) -> None:
        self.count += 1
        delta = x - self.mean
        self.mean += delta / self.count
        self.m2 += delta * (x - self.mean)

    @property
    def std(self) -> np.ndarray:
        if self.count < 2:
            return np.ones_like(self.mean)
        return np.maximum(np.sqrt(self.m2 / (self.count - 1)), 1e-2)  # type: ignore[no-any-return]


def rollout(env: Any, act: Callable[[np.ndarray], np.ndarray], seed: int,
            stats: RunningStats | None = None) -> tuple[float, bool, int]:
    """One episode with ``act``; returns (return, success, steps). Observations go into ``stats`` if given."""
    obs, info = env.reset(seed=seed)
    total, steps = 0.0, 0
    while True:
        if stats is not None:
            stats.push(obs.astype(np.float64))
        obs, reward, terminated, truncated, info = env.step(act(obs))
        total += reward
        steps += 1
        if terminated or truncated:
            return total, bool(info.get("is_success", False)), steps


@dataclass
class Result:
    """What a training run produced."""

    policy: Any
    success_rate: float
    eval_episodes: int
    wall_time: float
    env_steps: int


def evaluate(env: Any, policy: Any, episodes: int, seed: int = EVAL_SEED) -> float:
    """Success rate of ``policy`` over ``episodes`` episodes seeded ``seed``, ``seed + 1``, …"""
    return sum(rollout(env, policy.act, seed + i)[1] for i in range(episodes)) / episodes


def train(config: str | Path = CONFIG, *, observations: tuple[str, ...] | None = OBSERVATIONS,
          iterations: int = 30, directions: int = 8, top: int = 4,
          step_size: float = 0.1, noise: float = 0.1, episodes: int = 2, seed: int = 0,
          eval_episodes: int = 50, normalise: bool = True, fixed_episodes: bool = False,
          validation_episodes: int = 5,
          log: Callable[[str], None] = print) -> Result:
    """Train a linear policy on the env made from ``config`` with ARS; return it with its evaluated success rate."""
    import robokit.gym
    from robokit.gym.policy import LinearPolicy

    env = robokit.gym.make(config, **({"env__observations": list(observations)} if observations else {}))
    rng = np.random.default_rng(seed)
    n_obs, n_act = env.observation_space.shape[0], env.action_space.shape[0]
    policy = LinearPolicy.zeros(n_obs, n_act)
    if not normalise:
        policy.obs_std = np.full(n_obs, 0.1)
    stats = RunningStats(n_obs)
    t0, env_steps = time.perf_counter(), 0
    fixed = [int(v) for v in rng.integers(0, 2**31, episodes)]
    validation = [VALIDATION_SEED + i for i in range(validation_episodes)]
    best_score, best_policy = -np.inf, copy.deepcopy(policy)
    for it in range(iterations):
        deltas = rng.standard_normal((directions, n_act, n_obs + 1))  # weights and bias
        # the same episodes for every direction of an iteration (fixed ones: a deterministic objective)
        seeds = fixed if fixed_episodes else [int(v) for v in rng.integers(0, 2**31, episodes)]
        returns = np.zeros((directions, 2))
        successes = 0
        for k in range(directions):
            for s, sign in enumerate((1.0, -1.0)):
                d = sign * noise * deltas[k]
                trial = LinearPolicy(policy.W + d[:, :-1], policy.b + d[:, -1], policy.obs_mean, policy.obs_std)
                for seed_ in seeds:
                    ret, ok, steps = rollout(env, trial.act, seed_, stats)
                    returns[k, s] += ret / episodes
                    successes, env_steps = successes + ok, env_steps + steps
        best = np.argsort(-returns.max(axis=1))[:top]
        sigma = returns[best].std() + 1e-8
        step = sum((returns[k, 0] - returns[k, 1]) * deltas[k] for k in best)
        update = step_size / (top * sigma) * step
        policy.W, policy.b = policy.W + update[:, :-1], policy.b + update[:, -1]
        if normalise:
            policy.obs_mean, policy.obs_std = stats.mean.copy(), stats.std.copy()
        score = sum(rollout(env, policy.act, v)[0] for v in validation) / len(validation)
        if score > best_score:
            best_score, best_policy = score, copy.deepcopy(policy)
        log(f"iteration {it + 1:3d}: mean return {returns.mean():8.3f}  "
            f"rollout success {successes / (2 * directions * episodes):5.1%}  validation return {score:8.3f}  "
            f"env steps {env_steps}")
    policy = best_policy  # the iterate that did best on the validation episodes
    rate = evaluate(env, policy, eval_episodes)
    wall = time.perf_counter() - t0
    policy.env = dict(env.unwrapped.cfg.raw["env"]) if hasattr(env, "unwrapped") else None
    policy.meta = {"method": "ARS V2-t", "iterations": iterations, "directions": directions, "top": top,
                   "step_size": step_size, "noise": noise, "episodes": episodes, "seed": seed, "success_rate": rate,
                   "eval_episodes": eval_episodes, "env_steps": env_steps, "wall_time_s": round(wall, 1),
                   "config": Path(config).name if not isinstance(config, dict) else "<dict>"}
    env.close()
    return Result(policy, rate, eval_episodes, wall, env_steps)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(CONFIG))
    parser.add_argument("--observations", default=",".join(OBSERVATIONS),
                        help="comma-separated observation entries, or 'config' for the config's own")
    parser.add_argument("--iterations", type=int, default=30)
    parser.add_argument("--directions", type=int, default=8)
    parser.add_argument("--top", type=int, default=4)
    parser.add_argument("--step-size", type=float, default=0.1)
    parser.add_argument("--noise", type=float, default=0.1)
    parser.add_argument("--episodes", type=int, default=2, help="episodes per rollout (the same for every direction)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args(argv)
    observations = None if args.observations == "config" else tuple(args.observations.split(","))
    result = train(args.config, observations=observations, iterations=args.iterations, directions=args.directions,
                   top=args.top,
                   step_size=args.step_size, noise=args.noise, episodes=args.episodes, seed=args.seed,
                   eval_episodes=args.eval_episodes)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    result.policy.save(args.out)
    print(f"success rate {result.success_rate:.1%} over {result.eval_episodes} evaluation episodes; "
          f"{result.env_steps} training env steps in {result.wall_time:.1f} s wall; policy written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
