"""robokit configs as Gymnasium environments (``pip install 'robokit[gym]'``).

::

    import robokit.gym
    env = robokit.gym.make("configs/gym/reach.toml")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

    import gymnasium
    env = gymnasium.make("robokit/Env-v0", config="configs/gym/reach.toml")    # registered by `import robokit.gym`
    env = gymnasium.make("robokit/Reach-v0", goal_env=True)                    # a shipped env, HER-ready
    env = gymnasium.make("robokit.gym:robokit/Push-v0")                        # the same, importing it first
    env = gymnasium.make("robokit/Reach-v0", engine="mujoco")                  # on MuJoCo (or world__engine=)

Importing this package registers ``robokit/Env-v0`` and the shipped environments (``robokit/Reach-v0``,
``Push-v0``, ``Pick-v0``, ``GoTo-v0``, each also as ``...Dense-v0`` and ``...Sparse-v0``) when Gymnasium is
installed; without Gymnasium, tasks (:mod:`robokit.gym.task`) and the ``[env]`` section (:mod:`robokit.gym.spec`)
still work (numpy only).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

ENV_ID = "robokit/Env-v0"
CONFIG_DIR = Path(__file__).resolve().parents[2] / "configs" / "gym"
"""The shipped environment configs: ``configs/gym/`` of the source tree, installed with robokit as the data package
``robokit_configs.gym`` (see :func:`_config_dir`)."""


def _config_dir() -> Path:
    """Where the shipped env configs are: the source tree's ``configs/gym`` when there is one (an editable install,
    a checkout), else the copy installed with robokit."""
    if CONFIG_DIR.is_dir():
        return CONFIG_DIR
    from importlib.util import find_spec

    spec = find_spec("robokit_configs.gym")
    locations = list(spec.submodule_search_locations or []) if spec is not None else []
    return Path(locations[0]) if locations else CONFIG_DIR
SHIPPED = {"Reach": "reach.toml", "Push": "push.toml", "Pick": "pick.toml", "GoTo": "go_to.toml"}
"""Registered name -> config in :data:`CONFIG_DIR`."""


def make(config: str | Path | dict[str, Any], *, render_mode: str | None = None, goal_env: bool | None = None,
         engine: str | None = None, **overrides: Any) -> Any:
    """A :class:`~robokit.gym.env.RobokitEnv` from a config with an ``[env]`` section.

    Args:
        config: Path to a TOML config, or a dict as TOML parses it.
        render_mode: ``"rgb_array"`` to have ``render()`` return the ``[env] render_camera``'s RGB frame;
            ``"human"`` to watch the episodes in the engine's GUI window, paced to wall-clock time (PyBullet, with
            a display).
        goal_env: True for panda-gym's goal dict observation and a sparse reward unless the config names one
            (``[env] goal_env``; None keeps the config's).
        engine: ``"pybullet"`` or ``"mujoco"`` (None: the config's ``world.engine``).
        overrides: Dotted config keys with ``__`` for dots, e.g. ``env__task__reward="sparse"``,
            ``world__time_step=0.002``.
    """
    from robokit.gym.env import RobokitEnv

    return RobokitEnv(config, render_mode=render_mode, goal_env=goal_env, engine=engine, **overrides)


def make_shipped(name: str, reward: str | None = None, render_mode: str | None = None,
                 goal_env: bool | None = None, overrides: dict[str, Any] | None = None, engine: str | None = None,
                 **keys: Any) -> Any:
    """The entry point of the registered ids: shipped env ``name`` (see :data:`SHIPPED`) with a reward variant.

    ``engine``: ``"pybullet"`` (the configs' own) or ``"mujoco"``; ``keys``: config overrides as keywords with
    ``__`` for dots (``world__engine="mujoco"``, ``env__task__distance_threshold=0.02``)."""
    from robokit.gym.env import RobokitEnv

    path = _config_dir() / SHIPPED[name]
    if not path.is_file():
        raise FileNotFoundError(f"robokit/{name}-v0 needs {path}, which this install of robokit lacks: "
                                f"reinstall robokit (pip install .) or make the env from a config path")
    dotted = dict(overrides or {})
    if reward is not None:
        dotted["env.task.reward"] = reward
    return RobokitEnv(path, render_mode=render_mode, overrides=dotted, goal_env=goal_env, engine=engine, **keys)


def register_envs() -> None:
    """Register ``robokit/Env-v0`` and the shipped environments with Gymnasium (done on import of this package
    when Gymnasium is installed): ``robokit/NAME-v0`` (the config's reward: dense, or sparse in a goal env),
    ``robokit/NAMEDense-v0`` and ``robokit/NAMESparse-v0``."""
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(ENV_ID, entry_point="robokit.gym.env:RobokitEnv")
    for name in SHIPPED:
        for suffix, reward in (("", None), ("Dense", "dense"), ("Sparse", "sparse")):
            env_id = f"robokit/{name}{suffix}-v0"
            if env_id not in gymnasium.registry:
                gymnasium.register(env_id, entry_point="robokit.gym:make_shipped",
                                   kwargs={"name": name, "reward": reward})


try:
    register_envs()
except ImportError:  # Gymnasium is optional (robokit[gym]); the policy behaviour needs only numpy
    pass


__all__ = ["CONFIG_DIR", "ENV_ID", "SHIPPED", "make", "make_shipped", "register_envs"]
