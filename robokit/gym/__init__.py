"""robokit configs as Gymnasium environments (``pip install 'robokit[gym]'``).

::

    import robokit.gym
    env = robokit.gym.make("configs/gym/reach.toml")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

    import gymnasium
    env = gymnasium.make("robokit/Env-v0", config="configs/gym/reach.toml")    # registered by `import robokit.gym`
    env = gymnasium.make("robokit.gym:robokit/Env-v0", config=...)              # the same, importing it first

Importing this package registers ``robokit/Env-v0`` when Gymnasium is installed; without Gymnasium, tasks
(:mod:`robokit.gym.task`) and the ``[env]`` section (:mod:`robokit.gym.spec`) still work (numpy only).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

ENV_ID = "robokit/Env-v0"


def make(config: str | Path | dict[str, Any], *, render_mode: str | None = None, **overrides: Any) -> Any:
    """A :class:`~robokit.gym.env.RobokitEnv` from a config with an ``[env]`` section.

    Args:
        config: Path to a TOML config, or a dict as TOML parses it.
        render_mode: ``"rgb_array"`` to have ``render()`` return the ``[env] render_camera``'s RGB frame.
        overrides: Dotted config keys with ``__`` for dots, e.g. ``env__task__reward="sparse"``,
            ``world__time_step=0.002``.
    """
    from robokit.gym.env import RobokitEnv

    dotted = {key.replace("__", "."): value for key, value in overrides.items()}
    return RobokitEnv(config, render_mode=render_mode, overrides=dotted)


def register_envs() -> None:
    """Register ``robokit/Env-v0`` with Gymnasium (done on import of this package when Gymnasium is installed)."""
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(ENV_ID, entry_point="robokit.gym.env:RobokitEnv")


try:
    register_envs()
except ImportError:  # Gymnasium is optional (robokit[gym]); the policy behaviour needs only numpy
    pass


__all__ = ["ENV_ID", "make", "register_envs"]
