"""The ``[env]`` section: what an agent observes, what its actions drive, and the task. No Gymnasium here.

::

    [env]
    control_hz = 25                       # one env step = physics_hz / control_hz physics ticks (action repeat)
    observations = ["arm.position", "arm.velocity", "task.goal"]      # a flat Box, in this order
    # observations = { observation = ["arm.position", "arm.velocity"], desired_goal = "task.goal" }  # a Dict
    render_camera = "cam"                 # a camera sensor: env.render() returns its RGB frame

    [env.actions.arm]                     # actuator name -> what the action's slice becomes
    kind = "ee_delta"                     # ee_delta (3) · joint_targets (one per joint) · twist (2) · gripper (1)
    max_step = 0.05                       # metres per step at action 1.0

    [env.task]
    type = "reach"                        # a registered task type, with its own keys
    max_time = 2.0                        # sim seconds, then the episode is truncated

Every action is normalised to ``[-1, 1]``; each entry says what ``±1`` means in physical units. An observation
entry ``"NAME.field.sub"`` reads sensor or actuator ``NAME``'s reading and follows attributes or keys;
``"task.X"`` reads the task's observation ``X``. Numbers, sequences, mappings (values in order) and arrays are
flattened to float32.

This module is shared by the environment and by the ``policy`` behaviour, which must build the same observation
from the same readings and send the same commands.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from robokit.config import Schema

ActionKind = Literal["ee_delta", "joint_targets", "twist", "gripper"]


class ActionSpec(Schema):
    """``[env.actions.ACTUATOR]``: how a slice of the action vector (each entry in ``[-1, 1]``) drives an actuator.

    - ``ee_delta`` (3 entries, an ``ee_delta`` actuator): an end-effector step of up to ``max_step`` m per axis.
    - ``joint_targets`` (one per joint in ``joints``; ``joint_control`` or ``pid``): ``-1..1`` maps linearly to
      ``low..high`` (rad; default each joint's URDF limits).
    - ``twist`` (2 entries, ``diff_drive``): forward speed up to ``max_speed`` m/s, turn rate up to
      ``max_turn_rate`` rad/s.
    - ``gripper`` (1 entry, ``gripper``): ``-1`` closed … ``1`` open to ``max_width`` m.
    """

    kind: ActionKind
    max_step: float = Field(0.05, gt=0, description="ee_delta: metres per step at 1.0")
    joints: tuple[str, ...] = Field((), description="joint_targets: the joints, in action order")
    low: tuple[float, ...] | None = None
    high: tuple[float, ...] | None = None
    max_speed: float = Field(0.5, gt=0, description="twist: m/s at 1.0")
    max_turn_rate: float = Field(2.0, gt=0, description="twist: rad/s at 1.0")
    max_width: float = Field(0.08, gt=0, description="gripper: finger opening at 1.0, m")
    close_force: float | None = Field(None, gt=0, description="gripper: finger force, N")

    @model_validator(mode="after")
    def _joints(self) -> ActionSpec:
        if self.kind == "joint_targets" and not self.joints:
            raise ValueError("kind 'joint_targets' needs joints = [names, in action order]")
        for bound in (self.low, self.high):
            if bound is not None and len(bound) != len(self.joints):
                raise ValueError(f"low/high need one value per joint ({len(self.joints)})")
        return self

    @property
    def size(self) -> int:
        """Entries of the action vector this actuator takes."""
        return {"ee_delta": 3, "twist": 2, "gripper": 1}.get(self.kind, len(self.joints))


class TaskSpec(Schema):
    """``[env.task]``: ``type`` plus the task type's own keys (validated by its schema)."""

    model_config = Schema.model_config | {"extra": "allow"}
    type: str


class EnvSpec(Schema):
    """``[env]``: see the module docstring."""

    control_hz: float = Field(25.0, gt=0, description="env steps per sim second")
    observations: tuple[str, ...] | dict[str, str | tuple[str, ...]] = Field(min_length=1)
    actions: dict[str, ActionSpec] = Field(min_length=1)
    task: TaskSpec
    render_camera: str | None = None
    reset: Literal["auto", "restore", "rebuild"] = Field(
        "auto", description="restore the start state in place (fast) or rebuild the world; auto: restore when "
                            "every component can reset itself")

    @property
    def dict_observations(self) -> bool:
        """True when observations are a Dict space (a table of name -> entries)."""
        return isinstance(self.observations, dict)

    def observation_groups(self) -> dict[str, tuple[str, ...]]:
        """Observation key -> its entries (one group named ``"observation"`` for a flat Box)."""
        if isinstance(self.observations, dict):
            return {k: (v,) if isinstance(v, str) else tuple(v) for k, v in self.observations.items()}
        return {"observation": tuple(self.observations)}

    def action_repeat(self, physics_hz: float) -> int:
        """Physics ticks per env step; ``control_hz`` must divide the physics rate."""
        ratio = physics_hz / self.control_hz
        if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
            raise ValueError(f"control_hz {self.control_hz:g} does not divide the physics rate {physics_hz:g} Hz")
        return round(ratio)


def flatten(value: Any) -> list[float]:
    """A reading (number, sequence, mapping, array, dataclass of numbers) as a flat list of floats."""
    if type(value) is tuple and all(type(v) is float for v in value):  # the common case: a position
        return list(value)
    if isinstance(value, bool | int | float | np.number):
        return [float(value)]
    if isinstance(value, np.ndarray):
        return [float(v) for v in value.ravel()]
    if isinstance(value, Mapping):
        return [f for v in value.values() for f in flatten(v)]
    if isinstance(value, list | tuple):
        return [f for v in value for f in flatten(v)]
    raise TypeError(f"cannot make numbers of a {type(value).__name__}")


def lookup(value: Any, path: list[str], where: str) -> Any:
    """Follow attribute names or mapping keys along ``path``; an unknown one is a ValueError naming the choices."""
    for part in path:
        if isinstance(value, Mapping):
            if part not in value:
                raise ValueError(f"{where}: no key {part!r}; keys: {', '.join(map(str, value))}")
            value = value[part]
        elif hasattr(value, part):
            value = getattr(value, part)
        else:
            fields = [f for f in dir(value) if not f.startswith("_") and not callable(getattr(value, f))]
            raise ValueError(f"{where}: no field {part!r}; fields: {', '.join(fields)}")
    return value


class Observer:
    """Builds observations from readings and the task's observation, as the [env] section declares them."""

    def __init__(self, spec: EnvSpec) -> None:
        self.spec = spec
        self.groups = {k: [(e, e.split(".")) for e in v] for k, v in spec.observation_groups().items()}

    def observe(self, readings: Mapping[str, Any], task_obs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Observation arrays (float32) by group name."""
        out = {}
        for key, entries in self.groups.items():
            values: list[float] = []
            for entry, path in entries:
                if path[0] == "task":
                    source: Any = task_obs
                elif path[0] in readings:
                    source = readings[path[0]]
                else:
                    names = ", ".join(["task", *readings])
                    raise ValueError(f"env.observations: {entry!r}: unknown component {path[0]!r}; known: {names}")
                values.extend(flatten(lookup(source, path[1:], f"env.observations: {entry!r}")))
            out[key] = np.asarray(values, dtype=np.float32)
        return out


def _clip(a: Any) -> np.ndarray:
    return np.clip(np.asarray(a, dtype=np.float64), -1.0, 1.0)


class Actions:
    """Turns a normalised action vector into commands by actuator name (what the behaviour would send).

    Args:
        spec: The [env] section.
        joint_limits: For ``joint_targets`` without ``low``/``high``: ``(actuator, joint) -> (lower, upper)``.
    """

    def __init__(self, spec: EnvSpec, joint_limits: Mapping[tuple[str, str], tuple[float, float]]) -> None:
        self.items: list[tuple[str, ActionSpec, slice, Any]] = []
        start = 0
        for name, act in spec.actions.items():
            extra: Any = None
            if act.kind == "joint_targets":
                lows = act.low or tuple(joint_limits[(name, j)][0] for j in act.joints)
                highs = act.high or tuple(joint_limits[(name, j)][1] for j in act.joints)
                extra = (np.array(lows), np.array(highs))
            self.items.append((name, act, slice(start, start + act.size), extra))
            start += act.size
        self.size = start

    def commands(self, action: Any) -> dict[str, Any]:
        """Commands by actuator name for one action vector (values outside ``[-1, 1]`` are clipped)."""
        from robokit.msgs import EEDelta, GripperCommand, JointCommand, Twist

        a = _clip(action).reshape(-1)
        if a.shape[0] != self.size:
            raise ValueError(f"expected an action of {self.size} numbers, got {a.shape[0]}")
        out: dict[str, Any] = {}
        for name, act, sl, extra in self.items:
            part = a[sl]
            if act.kind == "ee_delta":
                d = part * act.max_step
                out[name] = EEDelta((float(d[0]), float(d[1]), float(d[2])))
            elif act.kind == "twist":
                out[name] = Twist(float(part[0] * act.max_speed), float(part[1] * act.max_turn_rate))
            elif act.kind == "gripper":
                width = (float(part[0]) + 1.0) / 2.0 * act.max_width
                out[name] = GripperCommand("width", width=width, force=act.close_force)
            else:
                lo, hi = extra
                values = lo + (part + 1.0) / 2.0 * (hi - lo)
                out[name] = JointCommand("position", {j: float(v) for j, v in zip(act.joints, values, strict=True)})
        return out


def finite_or(value: float, default: float) -> float:
    """``value`` if finite, else ``default`` (for joint limits of continuous joints)."""
    return value if math.isfinite(value) else default
