"""``RobokitEnv``: a robokit config as a Gymnasium environment. The same World, sensors, actuators and scheduler as
``robokit run``; the ``[env]`` section (see :mod:`robokit.gym.spec`) says what is observed, what the action
drives, and the task.

One env step sends the action's commands to the actuators, then runs ``physics_hz / control_hz`` ticks of the
ordinary loop (sensors, actuators, physics; the config's ``[behaviour]`` is not used). ``reset(seed=...)`` puts the
world back in its start state and lets the task place the goal and objects from the episode's generator: the
same seed gives the same episode, in one process or another.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from robokit.config import Config, build_config, read_toml, set_dotted, validate_model
from robokit.core.simulation import Simulation
from robokit.engines.interface import World
from robokit.errors import ConfigError, UserError
from robokit.gym.spec import Actions, EnvSpec, Observer, finite_or
from robokit.gym.task import Task, TaskContext
from robokit.plugin_api.plugins import Plugins, load_plugins


def load_env_config(config: str | Path | dict[str, Any], overrides: dict[str, Any] | None = None,
                    plugins: Plugins | None = None) -> tuple[Config, EnvSpec, Plugins]:
    """Read and validate a config with an ``[env]`` section (its ``[behaviour]`` is dropped).

    Raises:
        ConfigError: One line naming the file and the key path.
    """
    plugins = plugins or load_plugins()
    if isinstance(config, dict):
        raw, source, base = copy.deepcopy(config), "<dict>", Path.cwd()
    else:
        raw, source, base = read_toml(config), str(config), Path(config).resolve().parent
    for dotted, value in (overrides or {}).items():
        set_dotted(raw, dotted, value)
    raw.pop("behaviour", None)
    if "env" not in raw:
        raise ConfigError("no [env] section: say what is observed, what the actions drive and the task", file=source)
    task_raw = raw["env"].get("task")
    if raw["env"].get("goal_env") is True and isinstance(task_raw, dict):
        task_raw.setdefault("reward", "sparse")  # a goal environment's reward is sparse unless the config says
    if raw.get("events"):
        raise ConfigError("timed [[events]] are not supported in an environment", key="events", file=source)
    cfg = build_config(raw, plugins, source=source, base_dir=base)
    try:
        spec = validate_model(EnvSpec, raw["env"], "env")
        try:
            task_type = plugins.get("task", spec.task.type)
        except UserError as exc:
            raise ConfigError(str(exc), key="env.task.type") from None
        if task_type.schema is not None:
            validate_model(task_type.schema, {k: v for k, v in raw["env"]["task"].items() if k != "type"},
                           "env.task")
        spec.action_repeat(1.0 / cfg.world.time_step)
    except ValueError as exc:
        raise ConfigError(str(exc), key="env.control_hz", file=source) from None
    except ConfigError as exc:
        raise exc.within(file=source) from None
    return cfg, spec, plugins


class RobokitEnv(gym.Env):  # type: ignore[type-arg]
    """A Gymnasium environment built from a robokit config with an ``[env]`` section.

    Args:
        config: Path to a TOML config (or a dict as TOML parses it).
        render_mode: ``"rgb_array"`` (``render()`` returns the ``[env] render_camera`` sensor's RGB frame),
            ``"human"`` (the episode runs in the engine's GUI window, paced to wall-clock time unless
            ``[world] realtime = false``; ``render()`` returns None, as Gymnasium's human mode does) or None.
            An env's ``metadata["render_modes"]`` lists what its engine can do here: ``"rgb_array"`` when the
            config names a render camera, ``"human"`` when the engine's window can open (PyBullet with a display;
            MuJoCo has none). Asking for a mode the env cannot do raises one line saying why.
        overrides: Dotted keys set before validation, e.g. ``{"env.task.reward": "sparse"}``.
        engine: The physics engine (``"pybullet"``, ``"mujoco"``): the config's ``world.engine`` otherwise.
        keys: More overrides as keywords, ``__`` for dots: ``world__engine="mujoco"``, ``env__task__reward=...``.

    A goal env (``goal_env``: dict observations with ``achieved_goal`` and ``desired_goal``) has
    :meth:`compute_reward` (for HER's relabelling) and its step reward is that of its observed goals; a flat env
    has no ``compute_reward``, so tools that look for it (Stable-Baselines3) take it for what it is.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 25}
    """The modes an env may offer; each env's own ``metadata`` narrows them to what its engine can do."""
    sim: Simulation | None = None
    _episode_rng: np.random.Generator | None = None

    def __init__(self, config: str | Path | dict[str, Any], render_mode: str | None = None,
                 overrides: dict[str, Any] | None = None, plugins: Plugins | None = None,
                 goal_env: bool | None = None, engine: str | None = None, **keys: Any) -> None:
        overrides = {**(overrides or {}), **{key.replace("__", "."): value for key, value in keys.items()}}
        if goal_env is not None:
            overrides["env.goal_env"] = goal_env
        if engine is not None:
            overrides["world.engine"] = engine
        self.cfg, self.env_spec, self.plugins = load_env_config(config, overrides, plugins)
        modes, why_not = self._render_modes()
        if render_mode is not None and render_mode not in modes:
            if render_mode in why_not:
                raise ConfigError(f"render_mode={render_mode!r}: {why_not[render_mode]}",
                                  key="env.render_camera" if render_mode == "rgb_array" else "world.engine",
                                  file=self.cfg.source)
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self._build()
        self.observer = Observer(self.env_spec, self.task.goal_entries)
        self.metadata = {**self.metadata, "render_modes": modes, "render_fps": round(self.env_spec.control_hz)}
        if self.env_spec.goal_env:
            self.compute_reward = self._goal_reward
        self.action_space = spaces.Box(-1.0, 1.0, (self.actions.size,), dtype=np.float32)
        try:
            task_obs = self.task.observe()
            bounds = self.observer.fit_bounds(self._sim.readings, task_obs,
                                              {f"task.{k}": v for k, v in self.task.bounds().items()})
        except ValueError as exc:
            self.close()
            raise ConfigError(str(exc).removeprefix("env.observations: "), key="env.observations",
                              file=self.cfg.source) from None
        boxes: dict[str, spaces.Space[Any]] = {
            k: spaces.Box(lo, hi, lo.shape, dtype=lo.dtype) for k, (lo, hi) in bounds.items()}
        self.observation_space = spaces.Dict(boxes) if self.env_spec.dict_observations else boxes["observation"]
        self.restorable = self.env_spec.reset == "restore" or (
            self.env_spec.reset == "auto" and all(hasattr(c, "reset") for c in self._components()))
        if self.env_spec.reset == "restore" and not all(hasattr(c, "reset") for c in self._components()):
            missing = [n for n, c in self._sim.components.items() if not hasattr(c, "reset")]
            raise ConfigError(f"reset = 'restore' needs every component to have reset(); these have not: "
                              f"{', '.join(missing)}", key="env.reset", file=self.cfg.source)
        self.episode_ticks = 0
        self.closed = False

    # ------------------------------------------------------------------ building
    def _build(self, randomize_rng: np.random.Generator | None = None) -> None:
        if self.sim is not None:
            self.sim.close()
        self.sim = Simulation(self.cfg, self.plugins, randomize_rng=randomize_rng,
                              gui=True if self.render_mode == "human" else None)
        self.world = self.sim.world
        spec = self.env_spec
        self.repeat = spec.action_repeat(self.world.physics_hz)
        self.max_ticks = 0
        self.task = self._make_task()
        self.actions = Actions(spec, self._joint_limits())
        for name, act in spec.actions.items():
            if name not in self.sim.components:
                raise ConfigError(f"unknown actuator {name!r}; components: {', '.join(self.sim.components)}",
                                  key=f"env.actions.{name}", file=self.cfg.source)
            if act.kind == "joint_targets":
                for joint in act.joints:
                    self.world.joint(getattr(self.sim.components[name], "body", -1), joint)
        self.snapshot = self.world.snapshot()

    def _make_task(self) -> Task:
        assert self.sim is not None
        spec = self.env_spec.task
        ptype = self.plugins.get("task", spec.type, where="env.task.type")
        params = {k: v for k, v in (spec.model_extra or {}).items()}
        config = validate_model(ptype.schema, params, "env.task") if ptype.schema is not None else None
        task: Task = ptype.cls(spec.type, config)
        ctx = TaskContext(self.world, self.sim.readings, self.sim.components, self.cfg.base_dir)
        try:
            task.setup(ctx)
        except ConfigError as exc:
            raise exc.within(file=self.cfg.source) from None
        self.max_ticks = round(getattr(config, "max_time", 1e9) / self.world.time_step)
        return task

    def _joint_limits(self) -> dict[tuple[str, str], tuple[float, float]]:
        assert self.sim is not None
        out = {}
        for name, act in self.env_spec.actions.items():
            comp = self.sim.components.get(name)
            for joint in act.joints:
                info = self.world.joint(getattr(comp, "body", -1), joint)
                ok = info.upper > info.lower
                out[(name, joint)] = (finite_or(info.lower, -np.pi) if ok else -np.pi,
                                      finite_or(info.upper, np.pi) if ok else np.pi)
        return out

    def _render_modes(self) -> tuple[list[str], dict[str, str]]:
        """The render modes this env can do on its engine here, and why not for the others."""
        why_not = {}
        if self.env_spec.render_camera is None:
            why_not["rgb_array"] = "needs [env] render_camera = a camera sensor's name"
        problem = World.engine_class(self.cfg.world.engine).window_problem()
        if problem is not None:
            why_not["human"] = f"no window on {self.cfg.world.engine} here: {problem}"
        return [m for m in self.metadata["render_modes"] if m not in why_not], why_not

    @property
    def _paced(self) -> bool:
        """Human mode with ``[world] realtime`` on: each step waits until wall-clock time catches up with sim time."""
        return self.render_mode == "human" and self.cfg.world.realtime

    @property
    def _sim(self) -> Simulation:
        assert self.sim is not None, "the environment is closed"
        return self.sim

    def _components(self) -> list[Any]:
        return list(self._sim.components.values())

    # ------------------------------------------------------------------ the Gymnasium API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Start an episode: the world's start state, then the task places the goal and objects from the seed.
        After :meth:`close`, a reset builds the world again (Stable-Baselines3's checker closes, then resets)."""
        super().reset(seed=seed)
        rng = self._randomize_rng(seed)
        if self.sim is None:
            self._build(rng)
            self.closed = False
        elif self.restorable and not (rng is not None and self.cfg.randomize and self.cfg.randomize.params):
            self.world.restore(self.snapshot)
            if rng is not None and self.sim.randomizer is not None:  # type: ignore[union-attr]
                randomizer = self.sim.randomizer  # type: ignore[union-attr]
                randomizer.draw(self.world, self.sim.body_keys, rng)  # type: ignore[union-attr]
                randomizer.apply_world(self.world)
            for comp in self._components():
                comp.reset(self.np_random.spawn(1)[0])
            for slot in self.sim.scheduler.slots.values():  # type: ignore[union-attr]
                slot.stale, slot.value, slot.stamp = True, None, -1
        else:
            self._build(rng)
        self.task.reset(self.np_random)
        self.episode_ticks = 0
        if self._paced:
            self._sim.scheduler.start_pacing()  # type: ignore[union-attr]
        info = self._info()
        if self._sim.randomizer is not None:
            info["randomize"] = self._sim.randomizer.drawn
        return self._observation(), info

    def _randomize_rng(self, seed: int | None) -> np.random.Generator | None:
        """The generator this episode's ``[randomize]`` draws come from (None: keep the draws made at build).

        ``reset(seed=s)`` starts the stream a run with seed ``s`` draws from, so its first episode has that run's
        draws; later resets draw the next values of the same stream. A first reset without a seed takes a child
        of the env's ``np_random``.
        """
        spec = self.cfg.randomize
        if spec is None or not spec.per_episode:
            return None
        from robokit.core.randomize import generator

        if seed is not None:
            self._episode_rng = generator(seed)
        elif self._episode_rng is None:
            self._episode_rng = self.np_random.spawn(1)[0]
        return self._episode_rng

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Send the action's commands, run one control period, and score it."""
        assert self.sim is not None
        for name, cmd in self.actions.commands(action).items():
            self.sim.components[name].command(cmd)
        tick = self.sim.scheduler.tick
        for _ in range(self.repeat):
            tick()
        self.episode_ticks += self.repeat
        if self._paced:
            self.sim.scheduler.pace()  # type: ignore[union-attr]
        task = self.task
        failure = task.failure()
        success = bool(task.success())
        terminated = success or failure is not None
        truncated = not terminated and self.episode_ticks >= self.max_ticks
        info = self._info(success)
        if failure is not None:
            info["failure"] = failure
        obs = self._observe_raw()
        if self.env_spec.goal_env:  # the reward of the goals as observed: what compute_reward gives for them
            reward = float(self._goal_reward(obs["achieved_goal"], obs["desired_goal"], info))
        else:
            reward = float(task.reward())
        return obs if self.env_spec.dict_observations else obs["observation"], reward, terminated, truncated, info

    def _goal_reward(self, achieved_goal: Any, desired_goal: Any, info: Any) -> np.ndarray:
        """A goal env's ``compute_reward``: the reward for these goals (vectorised over leading axes, float64), as
        :meth:`step` gives it: for HER's relabelling. Sparse: 0 within the task's ``distance_threshold``, else -1;
        dense: minus the distance."""
        return np.asarray(self.task.compute_reward(np.asarray(achieved_goal), np.asarray(desired_goal), info),
                          dtype=np.float64)

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """The render camera's RGB frame (``H x W x 3`` uint8) in ``rgb_array`` mode; None otherwise (in ``human``
        mode the GUI window shows the episode as it runs)."""
        if self.render_mode != "rgb_array" or self.sim is None:
            return None
        frame = self.sim.readings[self.env_spec.render_camera]  # type: ignore[index]
        return np.asarray(frame.rgb, dtype=np.uint8)

    def close(self) -> None:
        """Close the World and its components. Safe to call twice; a later :meth:`reset` builds them again."""
        if self.sim is not None:
            self.task.close()
            self.sim.close()
            self.sim = None
        self.closed = True

    # ------------------------------------------------------------------ helpers
    def _observe_raw(self) -> dict[str, np.ndarray]:
        assert self.sim is not None
        return self.observer.observe(self.sim.readings, self.task.observe())

    def _observation(self) -> Any:
        obs = self._observe_raw()
        return obs if self.env_spec.dict_observations else obs["observation"]

    def _info(self, success: bool | None = None) -> dict[str, Any]:
        return {"is_success": bool(self.task.success()) if success is None else success,
                "sim_time": self.episode_ticks * self.world.time_step, **self.task.info()}
