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
    goal_env: bool = Field(False, description="a goal dict observation (observation, achieved_goal, desired_goal) "
                                              "and sparse reward by default, for HER")
    obs_limit: float = Field(10.0, gt=0, description="bound of observation entries without a natural one (m, m/s; "
                                                     "values beyond it are clipped)")
    reset: Literal["auto", "restore", "rebuild"] = Field(
        "auto", description="restore the start state in place (fast) or rebuild the world; auto: restore when "
                            "every component can reset itself")

    @property
    def dict_observations(self) -> bool:
        """True when observations are a Dict space (a table of name -> entries, or a goal environment)."""
        return isinstance(self.observations, dict) or self.goal_env

    def observation_groups(self, goal_entries: frozenset[str] = frozenset()) -> dict[str, tuple[str, ...]]:
        """Observation key -> its entries (one group named ``"observation"`` for a flat Box).

        In a goal environment with a flat list, the groups are panda-gym's: ``observation`` (the list without the
        task entries that depend on the goal, ``goal_entries``), ``achieved_goal`` (``task.achieved``) and
        ``desired_goal`` (``task.goal``): an observation must not depend on the goal for HER to relabel it.
        """
        if isinstance(self.observations, dict):
            return {k: (v,) if isinstance(v, str) else tuple(v) for k, v in self.observations.items()}
        if self.goal_env:
            kept = tuple(e for e in self.observations if not (e.startswith("task.") and e[5:] in goal_entries))
            return {"observation": kept, "achieved_goal": ("task.achieved",), "desired_goal": ("task.goal",)}
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

    def __init__(self, spec: EnvSpec, goal_entries: frozenset[str] = frozenset()) -> None:
        self.spec = spec
        self.groups = {k: [(e, e.split(".")) for e in v] for k, v in spec.observation_groups(goal_entries).items()}
        self.clip: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    @staticmethod
    def _value(readings: Mapping[str, Any], task_obs: Mapping[str, Any], entry: str, path: list[str]) -> Any:
        if path[0] == "task":
            source: Any = task_obs
        else:
            try:
                source = readings[path[0]]  # one look-up: ``in`` on the readings would compute the reading too
            except KeyError:
                names = ", ".join(["task", *readings])
                raise ValueError(
                    f"env.observations: {entry!r}: unknown component {path[0]!r}; known: {names}") from None
        if len(path) == 2 and not isinstance(source, Mapping) and hasattr(source, path[1]):
            return getattr(source, path[1])  # the common entry: one field of a reading
        return lookup(source, path[1:], f"env.observations: {entry!r}")

    def observe(self, readings: Mapping[str, Any], task_obs: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Observation arrays by group name: float32 vectors, or an image (a group of one image entry)."""
        out = {}
        for key, entries in self.groups.items():
            if len(entries) == 1:
                value = self._value(readings, task_obs, *entries[0])
                if isinstance(value, np.ndarray) and value.ndim >= 2:
                    out[key] = image = as_image(value)
                    if key in self.clip:
                        clip_into(image, *self.clip[key])
                    continue
            values: list[float] = []
            for entry, path in entries:
                value = self._value(readings, task_obs, entry, path)
                if isinstance(value, np.ndarray) and value.ndim >= 2:
                    raise ValueError(f"env.observations: {entry!r} is an image: give it a key of its own, e.g. "
                                     f"observations = {{ image = {entry!r}, state = [...] }}")
                values.extend(flatten(value))
            vector = out[key] = np.asarray(values, dtype=np.float32)
            if key in self.clip:
                clip_into(vector, *self.clip[key])
        return out

    def fit_bounds(self, readings: Mapping[str, Any], task_obs: Mapping[str, Any],
                   known: Mapping[str, tuple[Any, Any]]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Each group's bounds (low, high arrays of its shape), which :meth:`observe` clips to from now on.

        ``known``: natural bounds by entry (``"task.goal"``: the goal box); an RGB image is 0..255, a depth image
        0..the camera's far plane, a segmentation image -1 (background) up; every other number
        ``±spec.obs_limit``. A bound with low = high (a goal always on the table) is widened by 1 mm above: a Box
        with equal bounds is not a space Gymnasium accepts without a warning.
        """
        limit, self.clip = self.spec.obs_limit, {}
        self.observe(readings, task_obs)  # raises on an unknown entry or an image among numbers
        out = {}
        for key, entries in self.groups.items():
            value = self._value(readings, task_obs, *entries[0]) if len(entries) == 1 else None
            if isinstance(value, np.ndarray) and value.ndim >= 2:
                image = as_image(value)
                far = getattr(self._value(readings, task_obs, entries[0][0], entries[0][1][:-1]), "far", limit)
                lo, hi = {np.dtype(np.uint8): (0, 255), np.dtype(np.int32): (-1, np.iinfo(np.int32).max)}.get(
                    image.dtype, (0.0, float(far)))
                out[key] = (np.full(image.shape, lo, image.dtype), np.full(image.shape, hi, image.dtype))
                if image.dtype == np.float32:
                    self.clip[key] = out[key]
                continue
            lows: list[float] = []
            highs: list[float] = []
            for entry, path in entries:
                n = len(flatten(self._value(readings, task_obs, entry, path)))
                low, high = known.get(entry, (-limit, limit))
                lows.extend(np.broadcast_to(np.asarray(low, np.float64), (n,)).tolist())
                highs.extend(np.broadcast_to(np.asarray(high, np.float64), (n,)).tolist())
            lo32, hi32 = np.asarray(lows, np.float32), np.asarray(highs, np.float32)
            hi32 = np.where(hi32 > lo32, hi32, lo32 + np.float32(1e-3))  # a fixed value (a goal on the table)
            out[key] = self.clip[key] = (lo32, hi32)
        return out


def clip_into(a: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """Clip ``a`` in place (two ufunc calls: np.clip's dispatch costs more than the work on a few numbers)."""
    np.maximum(a, low, out=a)
    np.minimum(a, high, out=a)


def as_image(value: np.ndarray) -> np.ndarray:
    """A camera image as an observation: RGB stays ``(H, W, 3)`` uint8; a one-channel image (depth, segmentation)
    gets a channel axis, ``(H, W, 1)``, keeping its dtype (float32 metres, int32 body ids)."""
    if value.ndim == 2:
        value = value[:, :, None]
    if value.dtype == np.uint8:
        return value
    return value.astype(np.int32 if np.issubdtype(value.dtype, np.integer) else np.float32)


def _clip(a: Any) -> np.ndarray:
    out = np.array(a, dtype=np.float64)  # a copy: the caller's action is not changed
    np.maximum(out, -1.0, out=out)
    return np.minimum(out, 1.0, out=out)  # type: ignore[no-any-return]


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
