"""Train a policy on a robokit environment with stable-baselines3 (``pip install -e '.[rl]'``).

::

    python -m robokit.gym.train configs/gym/reach.toml --algo ppo --timesteps 40000 --seed 0
    python -m robokit.gym.train configs/gym/reach.toml --algo sac --her --goal-env --timesteps 20000
    robokit run runs/train/reach-ppo-s0/policy.toml            # the learned policy as a behaviour

Environments run in ``--envs`` worker processes (each builds its own World). The run folder (``--out``, default
``runs/train/<config>-<algo>-s<seed>``) receives:

- ``progress.jsonl``: one line every ``--log-every`` env steps: env steps, episodes, mean return and success rate
  of the last 100 episodes, wall seconds; the last line is the evaluation (``--eval-episodes`` fresh seeds);
- ``tb/``: the same, TensorBoard-readable (when the ``tensorboard`` package is installed; it is in ``[rl]``);
- ``policy.zip``: the SB3 model, carrying the ``[env]`` section it was trained with (as ``robokit_env.json``);
- ``policy.toml``: the env config with a ``[behaviour]`` of type ``policy`` that runs ``policy.zip``: ``robokit
  run`` it as it is.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import zipfile
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from robokit.gym.policy import ENV_MEMBER

ALGOS = ("ppo", "sac", "td3")
EVAL_SEED = 1_000_000


class TrainError(Exception):
    """A mistake in the command: one line, exit code 2."""


def parse_set(items: list[str]) -> dict[str, Any]:
    """``--set env.task.reward=sparse`` pairs as dotted overrides (values read as JSON when they parse)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.startswith("env."):
            raise TrainError(f"--set {item!r}: expected env.KEY=VALUE (only the [env] section can be changed)")
        try:
            out[key] = json.loads(text)
        except json.JSONDecodeError:
            out[key] = text
    return out


def env_overrides(args: argparse.Namespace) -> dict[str, Any]:
    overrides = parse_set(args.set)
    if args.observations:
        overrides["env.observations"] = [o for o in args.observations.split(",") if o]
    if args.goal_env:
        overrides["env.goal_env"] = True
    return overrides


def make_env(config: str, overrides: dict[str, Any]) -> Any:
    """One environment (in a worker process: the World is built there)."""
    from robokit.gym.env import RobokitEnv

    return RobokitEnv(config, overrides=overrides)


def build_model(args: argparse.Namespace, venv: Any, dict_obs: bool, tb: str | None) -> Any:
    import stable_baselines3 as sb3

    policy = "MultiInputPolicy" if dict_obs else "MlpPolicy"
    common: dict[str, Any] = {"seed": args.seed, "device": "cpu", "verbose": 0, "tensorboard_log": tb}
    if args.algo == "ppo":
        if args.her:
            raise TrainError("--her needs an off-policy algorithm (--algo sac or td3)")
        return sb3.PPO(policy, venv, n_steps=args.n_steps, batch_size=args.batch_size, gamma=args.gamma,
                       learning_rate=args.learning_rate, **common)
    extra: dict[str, Any] = {}
    if args.her:
        if not dict_obs:
            raise TrainError("--her needs a goal environment: add --goal-env (or [env] goal_env = true)")
        from stable_baselines3 import HerReplayBuffer

        extra = {"replay_buffer_class": HerReplayBuffer,
                 "replay_buffer_kwargs": {"n_sampled_goal": 4, "goal_selection_strategy": "future"}}
    cls = sb3.SAC if args.algo == "sac" else sb3.TD3
    return cls(policy, venv, batch_size=args.batch_size, gamma=args.gamma, learning_rate=args.learning_rate,
               learning_starts=args.learning_starts, **extra, **common)


def progress_line(env_steps: int, episodes: int, returns: list[float], successes: list[Any],
                  wall_s: float) -> dict[str, Any]:
    """One line of ``progress.jsonl``: env steps so far, episodes ended, mean return and success rate of the last
    episodes (``returns``, ``successes``: the window SB3 keeps, 100 episodes), wall seconds."""
    return {"env_steps": int(env_steps), "episodes": int(episodes),
            "return_mean": round(float(np.mean(returns)), 6) if returns else None,
            "success_rate": round(float(np.mean(successes)), 4) if successes else None,
            "window": len(returns), "wall_s": round(wall_s, 2)}


def progress_callback(path: Path, every: int, t0: float) -> Any:
    """An SB3 callback writing a progress line to ``path`` every ``every`` env steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class ProgressLog(BaseCallback):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.episodes, self.next_line, self.written = 0, every, -1

        def _on_step(self) -> bool:
            self.episodes += int(np.sum(self.locals.get("dones", ())))
            if self.num_timesteps >= self.next_line:
                self.next_line += every
                self.write()
            return True

        def _on_training_end(self) -> None:
            if self.written != self.num_timesteps:
                self.write()

        def write(self) -> None:
            model, self.written = self.model, self.num_timesteps
            line = progress_line(self.num_timesteps, self.episodes, [e["r"] for e in model.ep_info_buffer or ()],
                                 list(model.ep_success_buffer or ()), time.perf_counter() - t0)
            if line["success_rate"] is not None:
                self.logger.record("rollout/success_rate_window", line["success_rate"])
            with path.open("a") as f:
                f.write(json.dumps(line) + "\n")

    return ProgressLog()


def evaluate(model: Any, config: str, overrides: dict[str, Any], episodes: int) -> dict[str, Any]:
    """Deterministic actions on ``episodes`` fresh seeds: success rate and mean return."""
    env = make_env(config, overrides)
    successes, returns = 0, []
    for i in range(episodes):
        obs, info = env.reset(seed=EVAL_SEED + i)
        done, total = False, 0.0
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            total, done = total + float(reward), terminated or truncated
        successes += bool(info["is_success"])
        returns.append(total)
    env.close()
    return {"eval_episodes": episodes, "eval_success_rate": successes / max(episodes, 1),
            "eval_return_mean": round(float(np.mean(returns)), 6) if returns else None}


def env_section(config: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """The ``[env]`` section as trained (overrides applied, the reward made explicit)."""
    from robokit.gym.env import load_env_config

    _, spec, _ = load_env_config(config, overrides)
    raw = json.loads(spec.model_dump_json(exclude_none=True))
    return raw  # type: ignore[no-any-return]


def write_policy(run: Path, model: Any, config: str, env: dict[str, Any], facts: dict[str, Any]) -> Path:
    """``policy.zip`` (the model, carrying ``env``) and ``policy.toml`` (the env config running it)."""
    zip_path = run / "policy.zip"
    model.save(zip_path)
    with zipfile.ZipFile(zip_path, "a") as archive:
        archive.writestr(ENV_MEMBER, json.dumps({"env": env, "meta": facts}))
    text = Path(config).read_text()
    toml = run / "policy.toml"
    toml.write_text(
        f"# Written by python -m robokit.gym.train from {config}: the learned policy as a behaviour.\n"
        f"#   robokit run {toml}\n"
        f"# policy.zip carries the [env] section it was trained with (the one below, overrides applied).\n\n"
        f"{text.rstrip()}\n\n[behaviour]\ntype = \"policy\"\npolicy = \"policy.zip\"\n")
    return toml


def run_folder(args: argparse.Namespace) -> Path:
    """Where the run's files go: ``--out``, default ``runs/train/<config>-<algo>-s<seed>``."""
    return Path(args.out or Path("runs") / "train" / f"{Path(str(args.config)).stem}-{args.algo}-s{args.seed}")


def train(args: argparse.Namespace, log: Any = print) -> dict[str, Any]:
    """Train as ``args`` say; returns the summary (also the last line of ``progress.jsonl``)."""
    try:
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv
    except ImportError:
        raise TrainError("training needs stable-baselines3: pip install -e '.[rl]' (see docs/gym.md)") from None
    from gymnasium import spaces

    from robokit.config import read_toml
    from robokit.errors import ConfigError

    config = str(args.config)
    if not Path(config).is_file():
        raise TrainError(f"config {config!r} not found")
    if "behaviour" in read_toml(config):
        raise TrainError(f"{config}: has a [behaviour] section; give an env config (train writes its own behaviour)")
    overrides = env_overrides(args)
    try:
        env = env_section(config, overrides)
        probe = make_env(config, overrides)
    except ConfigError as exc:
        raise TrainError(str(exc)) from None
    dict_obs = isinstance(probe.observation_space, spaces.Dict)
    probe.close()
    run = run_folder(args)
    run.mkdir(parents=True, exist_ok=True)
    progress = run / "progress.jsonl"
    progress.write_text("")
    tb = None
    try:
        import tensorboard  # noqa: F401

        tb = str(run / "tb")
    except ImportError:
        pass
    import torch

    torch.set_num_threads(args.threads)  # small networks: more threads only spin against the env workers
    vec_cls = SubprocVecEnv if args.envs > 1 else DummyVecEnv
    venv = make_vec_env(partial(make_env, config, overrides), n_envs=args.envs, seed=args.seed, vec_env_cls=vec_cls)
    model = build_model(args, venv, dict_obs, tb)
    t0 = time.perf_counter()
    every = args.log_every or (args.n_steps * args.envs if args.algo == "ppo" else 1000)
    try:
        model.learn(total_timesteps=args.timesteps, callback=progress_callback(progress, every, t0),
                    tb_log_name=args.algo)
    finally:
        venv.close()
    train_s = time.perf_counter() - t0
    facts = {"method": f"stable-baselines3 {args.algo.upper()}" + (" + HER" if args.her else ""),
             "env_steps": int(model.num_timesteps), "seed": args.seed, "envs": args.envs,
             "train_wall_s": round(train_s, 2), "config": config}
    summary = {**facts, **evaluate(model, config, overrides, args.eval_episodes)}
    toml = write_policy(run, model, config, env, summary)
    with progress.open("a") as f:
        f.write(json.dumps({"summary": summary}) + "\n")
    log(f"{summary['method']}: {summary['env_steps']} env steps in {train_s:.1f} s wall; success rate "
        f"{100 * summary['eval_success_rate']:.1f}% over {args.eval_episodes} evaluation episodes")
    log(f"policy: {run / 'policy.zip'}; run it: robokit run {toml}")
    return summary


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m robokit.gym.train", description="Train a policy with stable-baselines3 "
                                "on a robokit env config.")
    p.add_argument("config", help="a config with an [env] section, e.g. configs/gym/reach.toml")
    p.add_argument("--algo", choices=ALGOS, default="ppo")
    p.add_argument("--timesteps", type=int, default=100_000, help="env steps in all")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--envs", type=int, default=2, help="environments, each in its own process (1: in this one)")
    p.add_argument("--out", default=None, help="run folder (default runs/train/<config>-<algo>-s<seed>)")
    p.add_argument("--goal-env", action="store_true", help="the goal dict observation (sparse reward by default)")
    p.add_argument("--her", action="store_true", help="hindsight experience replay (sac/td3 with --goal-env)")
    p.add_argument("--observations", default="", help="comma-separated observation entries replacing the config's")
    p.add_argument("--set", action="append", default=[], metavar="env.KEY=VALUE", help="change the [env] section")
    p.add_argument("--threads", type=int, default=1, help="torch threads in the learner")
    p.add_argument("--eval-episodes", type=int, default=100)
    p.add_argument("--log-every", type=int, default=0, help="env steps between progress lines (default: a rollout)")
    p.add_argument("--n-steps", type=int, default=512, help="PPO: steps per env per rollout")
    p.add_argument("--batch-size", type=int, default=256)
    p.add_argument("--gamma", type=float, default=0.95)
    p.add_argument("--learning-rate", type=float, default=1e-3)
    p.add_argument("--learning-starts", type=int, default=1000, help="SAC/TD3: random steps before learning")
    p.add_argument("--report-url", metavar="URL", help="post progress.jsonl to the course server when done (its "
                   "results URL, as for robokit run; the token in $ROBOKIT_TOKEN): your dashboard plots it")
    p.add_argument("--token-env", metavar="NAME", help="variable holding your token (default ROBOKIT_TOKEN)")
    return p


def main(argv: list[str] | None = None) -> int:
    from robokit.gym.post import PostError, post_file, token_from, training_url

    args = parser().parse_args(argv)
    try:
        if args.report_url:  # checked before training, not after it
            training_url(args.report_url)
            token_from(args.token_env)
        train(args)
    except (TrainError, PostError) as exc:
        print(f"train: error: {exc}", file=sys.stderr)
        return 2
    if args.report_url:
        progress = run_folder(args) / "progress.jsonl"
        try:
            print(post_file(progress, args.report_url, token_env=args.token_env))
        except PostError as exc:
            print(f"train: error: {exc}; post it later: python -m robokit.gym.post {progress} --report-url "
                  f"{args.report_url}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
