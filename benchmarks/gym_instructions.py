"""Instructions per env step of robokit's gym envs on each engine, by valgrind's callgrind: a figure the machine's
load does not change (wall and CPU times on a shared machine do).

    python benchmarks/gym_instructions.py                       # Reach, Push, Pick on PyBullet and MuJoCo
    python benchmarks/gym_instructions.py --tasks Pick --engines mujoco --steps 200

Each env is made through ``gymnasium.make``, reset with seed 5 and stepped with uniformly random actions (seed 7),
resetting when an episode ends: ``--steps`` steps uncounted first (every path taken once), then ``--steps`` more
counted (only what runs inside ``functools.reduce``, which nothing in an env step enters). It prints instructions
per env step and, per task, PyBullet's count over MuJoCo's: how many MuJoCo steps one PyBullet step pays for.
"""

from __future__ import annotations

import argparse
import functools
import subprocess
import sys
import tempfile
from pathlib import Path


def steps_only(task: str, engine: str, steps: int) -> None:
    """``--count-only``: the counted env steps (run under callgrind)."""
    import gymnasium
    import numpy as np

    import robokit.gym  # noqa: F401 - registers robokit/Reach-v0 ...

    env = gymnasium.make(f"robokit/{task}-v0", engine=engine)
    env.reset(seed=5)
    rng = np.random.default_rng(7)
    actions = rng.uniform(-1, 1, (2 * steps, *env.action_space.shape)).astype(np.float32)

    def run(chunk: np.ndarray) -> None:
        for action in chunk:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()

    run(actions[:steps])
    functools.reduce(lambda _a, _b: run(actions[steps:]), (None, None))
    env.close()


def count(task: str, engine: str, steps: int) -> float:
    """Instructions per env step of ``task`` on ``engine``."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", "--collect-atstart=no", "--toggle-collect=functools_reduce",
                        f"--callgrind-out-file={out}", sys.executable, __file__, "--count-only", task, engine,
                        "--steps", str(steps)], check=True, capture_output=True, text=True)
        total = next(line for line in out.read_text().splitlines() if line.startswith(("summary:", "totals:")))
    return int(total.split()[1]) / steps


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=["Reach", "Push", "Pick"])
    parser.add_argument("--engines", nargs="+", default=["pybullet", "mujoco"])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--count-only", nargs=2, metavar=("TASK", "ENGINE"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.count_only:
        steps_only(*args.count_only, args.steps)
        return 0
    for task in args.tasks:
        per_step = {engine: count(task, engine, args.steps) for engine in args.engines}
        line = "  ".join(f"{engine} {n / 1e6:6.2f} M" for engine, n in per_step.items())
        ratio = (f"  pybullet / mujoco {per_step['pybullet'] / per_step['mujoco']:.2f}"
                 if {"pybullet", "mujoco"} <= per_step.keys() else "")
        print(f"{task:6} instructions per env step: {line}{ratio}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
