"""Hash the simulated state of the main configs and of random gym steps, to check a speed change is bit-identical.

    python benchmarks/state_hashes.py [--engines pybullet mujoco] [--gym-steps 300] > before.txt
    ... change the code ...
    python benchmarks/state_hashes.py > after.txt && diff before.txt after.txt

Every body's pose and velocity and every joint's position and velocity are hashed every 50 ticks (configs) or
after every step together with the observation, reward and scalar infos (gym envs).
"""
from __future__ import annotations

import argparse
import hashlib
import pathlib
import sys

import numpy as np

CONFIGS = (("sort_robot", 3, 1500), ("pick_place", 1, 1500), ("patrol_robot", 2, 1500),
           ("pick_place_suction", 0, 800), ("contact_abort", 0, 600), ("patrol_pickup", 0, 1500))
TASKS = ("Reach", "Push", "Pick")
ROOT = pathlib.Path(__file__).resolve().parent.parent


def world_state(world) -> bytes:
    """Poses, velocities and joint states of every body, as bytes."""
    parts = []
    for name in world.body_names:
        body = world.body(name)
        parts.append(world.pose(body))
        parts.append(world.velocity(body))
        joints = [j.index for j in world.joints(body)]
        if joints:
            parts.append([tuple(state)[:2] for state in world.joint_states(body, joints)])
    return repr(parts).encode()


def config_hashes(engine: str) -> dict[str, str]:
    from robokit.config import load_config
    from robokit.core.simulation import Simulation
    from robokit.plugin_api.plugins import load_plugins

    plugins = load_plugins()
    out = {}
    for name, seed, ticks in CONFIGS:
        cfg = load_config(ROOT / "configs" / f"{name}.toml", plugins, {"world.engine": engine, "world.seed": seed})
        acc = hashlib.sha256()
        with Simulation(cfg, plugins) as sim:
            try:
                for _ in range(ticks // 50):
                    sim.step(50)
                    acc.update(world_state(sim.world))
            except Exception as exc:  # a run that faults hashes its fault
                print(f"{engine} {name}: {exc!r}", file=sys.stderr)
                acc.update(repr(exc).encode())
        out[f"{engine} {name}"] = acc.hexdigest()[:16]
    return out


def gym_hashes(engine: str, steps: int) -> dict[str, str]:
    import gymnasium

    import robokit.gym  # noqa: F401  (registers the ids)

    out = {}
    for task in TASKS:
        env = gymnasium.make(f"robokit/{task}-v0", engine=engine)
        env.reset(seed=5)
        rng = np.random.default_rng(7)
        acc = hashlib.sha256()
        for _ in range(steps):
            obs, reward, terminated, truncated, info = env.step(
                rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
            acc.update(np.asarray(obs).tobytes())
            acc.update(np.float64(reward).tobytes())
            acc.update(repr(sorted((k, v) for k, v in info.items() if isinstance(v, (int, float, bool)))).encode())
            if terminated or truncated:
                env.reset()
        out[f"{engine} gym {task}"] = acc.hexdigest()[:16]
        env.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engines", nargs="+", default=["pybullet", "mujoco"])
    parser.add_argument("--gym-steps", type=int, default=300)
    parser.add_argument("--no-configs", action="store_true", help="hash only the gym envs")
    args = parser.parse_args()
    for engine in args.engines:
        hashes = gym_hashes(engine, args.gym_steps)
        if not args.no_configs:
            hashes.update(config_hashes(engine))
        for key, value in hashes.items():
            print(f"{key:32} {value}", flush=True)


if __name__ == "__main__":
    main()
