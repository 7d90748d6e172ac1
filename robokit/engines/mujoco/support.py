"""What the mujoco engine honours of a config, checked before anything is built: a refusal is one line naming the
key and the engine (a :class:`ConfigError`, exit code 2), never a failure halfway through a run.

Every plugin type runs: plugins and behaviours talk to physics only through the World, which the mujoco engine
answers whole. What is refused is what the engine cannot build: SDF bodies and a GUI window.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robokit.errors import ConfigError

if TYPE_CHECKING:  # read by attribute only
    from robokit.config import BodyConfig, Config

ENGINE = "the mujoco engine"


def check_config(cfg: Config, *, gui: bool | None = None) -> None:
    """Refuse, before the run, the first thing in ``cfg`` the mujoco engine cannot honour (the mujoco engine's
    :meth:`~robokit.engines.interface.World.check_config`). ``gui`` (the run's ``--gui`` override) is honoured:
    MuJoCo's own viewer is the window.

    Raises:
        ConfigError: One line: the file, the key, what is refused on mujoco and why.
    """
    problem = _bodies(cfg)
    if problem is not None:
        key, why = problem
        raise ConfigError(f"not supported on {ENGINE}: {why} (--engine pybullet runs it)", key=key, file=cfg.source)


def _bodies(cfg: Config) -> tuple[str, str] | None:
    for section, bodies in (("bodies", cfg.bodies), ("robots", cfg.robots)):
        for name, body in bodies.items():
            problem = _body(body)
            if problem is not None:
                return f"{section}.{name}.{problem[0]}", problem[1]
    return None


def _body(body: BodyConfig) -> tuple[str, str] | None:
    if body.sdf is not None:
        return "sdf", "SDF files are not loaded (URDF and primitives are)"
    return None
