"""What the mujoco engine honours of a config, checked before anything is built: a refusal is one line naming the
key and the engine (a :class:`ConfigError`, exit code 2), never a failure halfway through a run.

Third-party plugin types are let through: they are written against the World and run on both engines. robokit's
own types that still reach past the World into PyBullet, or need a World feature the mujoco engine lacks, are
listed in :data:`NOT_YET` with the reason.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from robokit.errors import ConfigError

if TYPE_CHECKING:  # read by attribute only: the engines sit below robokit.config in the house
    from robokit.config import BodyConfig, ComponentSpec, Config
    from robokit.engines.interface import World

ENGINE = "the mujoco engine"

NOT_YET: dict[str, str] = {
}
"""robokit's own plugin types that do not run on mujoco yet -> why."""


def check_config(cfg: Config) -> None:
    """Refuse, before the run, the first thing in ``cfg`` the mujoco engine cannot honour.

    Raises:
        ConfigError: One line: the file, the key, what is refused on mujoco and why.
    """
    problem = _world(cfg) or _bodies(cfg) or _components(cfg)
    if problem is not None:
        key, why = problem
        raise ConfigError(f"not supported on {ENGINE}: {why} (--engine pybullet runs it)", key=key, file=cfg.source)


def _world(cfg: Config) -> tuple[str, str] | None:
    if cfg.world.gui:
        return "world.gui", "no GUI window"
    return None


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
    if body.mjcf is not None:
        return "mjcf", "MJCF bodies are not loaded through robokit yet"
    return None


def _components(cfg: Config) -> tuple[str, str] | None:
    specs: list[ComponentSpec] = [*cfg.sensors, *cfg.actuators, *cfg.monitors, *cfg.recoveries.values()]
    stack = [cfg.behaviour] if cfg.behaviour is not None else []
    while stack:
        spec = stack.pop()
        specs.append(spec)
        stack.extend(spec.children)
    for spec in specs:
        if spec.type in NOT_YET:
            return f"{spec.key}.type", f"{spec.kind} type {spec.type!r}, {NOT_YET[spec.type]}"
    return None


def open_world(config: Config, *, gui: bool, seed: int) -> World:
    """A MuJoCo World for ``config`` (its ``[world]`` settings; ``seed`` and ``gui`` as the run overrides them).

    Raises:
        UserError: MuJoCo is not installed (one line naming the extra).
        ConfigError: The config asks for something the mujoco engine cannot honour (one line naming the key).
    """
    from robokit.engines.interface import World

    engine = World.engine_class("mujoco")  # first: a missing MuJoCo is one line naming the extra
    check_config(config)
    if gui:
        raise ConfigError(f"--gui: no GUI window on {ENGINE} (--engine pybullet has one)", key="world.gui",
                          file=config.source)
    wc = config.world
    return engine(time_step=wc.time_step, gravity=wc.gravity, solver_iterations=wc.solver_iterations, seed=seed,
                  base_dir=config.base_dir)
