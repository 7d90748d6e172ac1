"""``policy`` behaviour: run a learned policy — the same observations in, the same commands out as in training.

::

    [behaviour]
    type = "policy"
    policy = "policies/reach_linear.npz"     # relative to the config file; or an SB3 .zip with env_config
    # env_config = "gym/reach.toml"          # whose [env] section to use (default: the one saved in the policy)

Every ``physics_hz / control_hz`` ticks (the env step of training) the behaviour builds the observation from the
readings and the task, asks the policy for an action and sends the commands it maps to. The task (from the
``[env]`` section) places its goal and objects from the run's seed when the run starts; the run **succeeds** when
the task succeeds and **fails** when the task's ``max_time`` passes first (or the task fails). The result holds
the steps taken, the return, and the task's figures (e.g. the final distance).
"""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema, read_toml, validate_model
from robokit.errors import ConfigError, UserError

if TYPE_CHECKING:
    from robokit.gym.spec import EnvSpec
    from robokit.gym.task import Task


class PolicyConfig(Schema):
    """``policy``: the saved policy (``.npz`` linear or SB3 ``.zip``), relative to the config file;
    ``env_config``: a config whose ``[env]`` section to use instead of the one saved in the policy."""

    policy: str = Field(description="policy file, relative to the config")
    env_config: str | None = Field(None, description="a config with the [env] section the policy was trained on")


class PolicyBehaviour(Behaviour):
    """Runs a learned policy: observation from readings, action from the policy, commands to the actuators."""

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        # imported here, not at module level: plugin loading stays cheap for every run that does not use it
        from robokit.gym.policy import load_policy
        from robokit.gym.spec import Actions, EnvSpec, Observer

        cfg: PolicyConfig = self.config
        base = Path(ctx.config_dir)
        try:
            self.policy = load_policy(base / cfg.policy)
        except ValueError as exc:
            raise ConfigError(str(exc), key="policy") from None
        env_raw = self._env_section(base)
        if env_raw.get("goal_env") is True and isinstance(env_raw.get("task"), dict):
            env_raw["task"].setdefault("reward", "sparse")  # as the environment does
        self.spec: EnvSpec = validate_model(EnvSpec, env_raw, "env")
        for name in self.spec.actions:
            if name not in ctx.components:
                raise ConfigError(f"the policy drives actuator {name!r}, which this config lacks; components: "
                                  f"{', '.join(ctx.components)}", key="policy")
        self.actions = Actions(self.spec, self._joint_limits())
        self.task = self._task(env_raw)
        self.observer = Observer(self.spec, self.task.goal_entries)
        self.bounded = False
        self.task.reset(ctx.rng)
        self.repeat = self.spec.action_repeat(ctx.world.physics_hz)
        self.max_steps = max(1, round(self.task.config.max_time * self.spec.control_hz))
        self.steps, self.total_reward = 0, 0.0

    def _env_section(self, base: Path) -> dict[str, Any]:
        cfg: PolicyConfig = self.config
        if cfg.env_config is not None:
            raw = read_toml(base / cfg.env_config)
            if "env" not in raw:
                raise ConfigError(f"{cfg.env_config} has no [env] section", key="env_config")
            return copy.deepcopy(dict(raw["env"]))
        if getattr(self.policy, "env", None) is None:
            raise ConfigError("the policy file carries no [env] section: give env_config = a config with one",
                              key="env_config")
        return copy.deepcopy(dict(self.policy.env))  # type: ignore[arg-type]

    def _joint_limits(self) -> dict[tuple[str, str], tuple[float, float]]:
        from robokit.gym.spec import finite_or

        world, out = self.ctx.world, {}
        for name, act in self.spec.actions.items():
            for joint in act.joints:
                info = world.joint(getattr(self.ctx.components[name], "body", -1), joint)
                out[(name, joint)] = (finite_or(info.lower, -3.14159), finite_or(info.upper, 3.14159))
        return out

    def _task(self, env_raw: Mapping[str, Any]) -> Task:
        from robokit.gym.task import TaskContext
        from robokit.plugin_api.plugins import load_plugins

        plugins = load_plugins()
        try:
            ptype = plugins.get("task", self.spec.task.type, where="env.task.type")
        except UserError as exc:
            raise ConfigError(str(exc), key="policy") from None
        params = {k: v for k, v in env_raw["task"].items() if k != "type"}
        config = validate_model(ptype.schema, params, "env.task") if ptype.schema is not None else None
        task: Task = ptype.cls(self.spec.task.type, config)
        ctx = self.ctx
        task.setup(TaskContext(ctx.world, ctx.readings, ctx.components, ctx.config_dir))
        return task

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        tick = round(self.elapsed(t) / self.ctx.world.time_step)  # ticks since this behaviour started
        if tick % self.repeat:
            return None
        if self.steps > 0:
            self.total_reward += float(self.task.reward())
            failure = self.task.failure()
            if self.task.success():
                self.finish("succeeded", f"task {self.spec.task.type!r} achieved after {self.steps} step(s)")
                return None
            if failure is not None:
                self.finish("failed", failure)
                return None
            if self.steps >= self.max_steps:
                self.finish("failed", f"task {self.spec.task.type!r} not achieved in {self.task.config.max_time:g} s")
                return None
        task_obs = self.task.observe()
        if not self.bounded:  # the same bounds (and clipping) as the environment's observation space
            self.observer.fit_bounds(readings, task_obs, {f"task.{k}": v for k, v in self.task.bounds().items()})
            self.bounded = True
        obs = self.observer.observe(readings, task_obs)
        flat = obs if self.spec.dict_observations else obs["observation"]
        self.steps += 1
        return self.actions.commands(self.policy.act(flat))

    def result(self) -> dict[str, Any]:
        info = self.task.info() if hasattr(self, "task") else {}
        return {"steps": self.steps, "return": round(self.total_reward, 6),
                "success": bool(self.outcome is not None and self.outcome.status == "succeeded"),
                **{k: (round(v, 6) if isinstance(v, float) else v) for k, v in info.items()},
                "policy": json.loads(json.dumps(getattr(self.policy, "meta", {}), default=str))}

    def close(self) -> None:
        if hasattr(self, "task"):
            self.task.close()


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("policy", PolicyBehaviour, PolicyConfig)
