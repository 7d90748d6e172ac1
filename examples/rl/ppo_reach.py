"""Train PPO (stable-baselines3) on robokit's ``reach`` — optional: needs ``pip install stable-baselines3``,
which pulls PyTorch (not a robokit dependency, not installed in CI).

    pip install stable-baselines3
    python examples/rl/ppo_reach.py --timesteps 200000 --envs 2      # writes configs/policies/reach_ppo.zip
    robokit run configs/reach_policy.toml --json                     # after pointing it at the .zip:
    #   [behaviour] type = "policy", policy = "policies/reach_ppo.zip", env_config = "gym/reach.toml"

Two environments run in worker processes (``SubprocVecEnv``; each builds its own World). The success rate over
100 fresh seeds is printed at the end.
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "gym" / "reach.toml"
OUT = ROOT / "configs" / "policies" / "reach_ppo.zip"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Train PPO on robokit's reach")
    parser.add_argument("--config", default=str(CONFIG))
    parser.add_argument("--timesteps", type=int, default=200_000)
    parser.add_argument("--envs", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args(argv)
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import SubprocVecEnv
    except ImportError:
        print("ppo_reach: error: needs stable-baselines3 (pip install stable-baselines3)", file=sys.stderr)
        return 2
    import robokit.gym

    venv = make_vec_env(partial(robokit.gym.make, args.config), n_envs=args.envs, seed=args.seed,
                        vec_env_cls=SubprocVecEnv)
    model = PPO("MlpPolicy", venv, seed=args.seed, n_steps=1024, batch_size=256, verbose=1, device="cpu")
    model.learn(total_timesteps=args.timesteps)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    model.save(args.out)
    venv.close()
    env = robokit.gym.make(args.config)
    successes = 0
    for i in range(100):
        obs, info = env.reset(seed=1_000_000 + i)
        done = False
        while not done:
            action, _ = model.predict(np.asarray(obs), deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        successes += bool(info["is_success"])
    env.close()
    print(f"success rate {successes}% over 100 evaluation episodes; model written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
