"""``python -m robokit.train CONFIG --algo ppo --timesteps N --seed S``: see :mod:`robokit.gym.train`."""

from __future__ import annotations

import sys

from robokit.gym.train import main

if __name__ == "__main__":
    sys.exit(main())
