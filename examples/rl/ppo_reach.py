"""Train PPO (stable-baselines3) on robokit's ``reach``: the documented ``python -m robokit.gym.train`` run.

    pip install torch --index-url https://download.pytorch.org/whl/cpu   # torch's CPU build first
    pip install -e '.[rl]'
    python examples/rl/ppo_reach.py                          # = python -m robokit.gym.train configs/gym/reach.toml
                                                             #     --algo ppo --timesteps 40000 --seed 0
    robokit run runs/train/reach-ppo-s0/policy.toml          # the learned policy as a behaviour, unedited

Extra arguments go to ``robokit.gym.train`` (``--timesteps``, ``--seed``, ``--envs``, ``--out``, ...; later ones win).
"""

from __future__ import annotations

import sys
from pathlib import Path

from robokit.gym.train import main

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "gym" / "reach.toml"

if __name__ == "__main__":
    sys.exit(main([str(CONFIG), "--algo", "ppo", "--timesteps", "40000", "--seed", "0", *sys.argv[1:]]))
