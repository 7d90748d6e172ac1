"""TOML in, frozen typed objects out.

Every problem is a :class:`~robokit.errors.ConfigError` whose text is one line: the file, the key path, and what
was expected against what was found. Unknown keys are errors with a "did you mean". Plugin sections are validated
by the schema their type registered.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import CoreSchema

from robokit.errors import ConfigError, UserError, did_you_mean

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]

FLOAT_LIMIT = 1e9
"""Every float in a :class:`Schema` is finite and within ``±FLOAT_LIMIT`` unless its field says otherwise."""
MAX_CONFIG_BYTES = 4 * 1024 * 1024
"""A config file larger than this is refused unread (a config is a few kilobytes of TOML)."""

Coord = Annotated[float, Field(ge=-1e4, le=1e4, description="metres, world frame")]
"""A position coordinate in metres: within ±10 km of the origin."""
Angle = Annotated[float, Field(ge=-720.0, le=720.0, description="degrees")]
Unit = Annotated[float, Field(ge=0.0, le=1.0)]
Length = Annotated[float, Field(gt=0, le=1e3, description="metres")]
Position = tuple[Coord, Coord, Coord]
Gravity = Annotated[float, Field(ge=-1000.0, le=1000.0, description="m/s^2")]
Newtons = Annotated[float, Field(ge=-1e6, le=1e6, description="newtons")]

_STRICT_SCALARS = frozenset({"int", "float", "bool", "str"})


def _harden(node: Any, owner: type) -> None:
    """Make every scalar in a core schema strict; floats finite and within ``±FLOAT_LIMIT`` by default.

    Strict scalars refuse ``true`` for a number, ``1`` or ``"no"`` for a bool and numbers for strings, while
    containers stay lax (a TOML array is accepted for a tuple) and an integer is still accepted for a float.
    Nested models are left alone: each :class:`Schema` subclass hardens its own fields.
    """
    if isinstance(node, dict):
        if node.get("type") == "model" and node.get("cls") is not owner:
            return
        kind = node.get("type")
        if isinstance(kind, str) and kind in _STRICT_SCALARS:
            node["strict"] = True
        if kind == "float":
            node["allow_inf_nan"] = False
            if "le" not in node and "lt" not in node:
                node["le"] = FLOAT_LIMIT
            if "ge" not in node and "gt" not in node:
                node["ge"] = -FLOAT_LIMIT
        for value in node.values():
            _harden(value, owner)
    elif isinstance(node, list):
        for value in node:
            _harden(value, owner)


class Schema(BaseModel):
    """Base of every config model: frozen, unknown keys rejected, strict types, finite numbers.

    Plugin schemas should subclass it; they inherit the rules: no bool for a number or a number for a bool, no
    string for a bool, every float finite and within ``±FLOAT_LIMIT`` unless the field declares its own bounds
    (declare physically meaningful ones with ``Field(ge=..., le=...)``). An integer is accepted for a float.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @classmethod
    def __get_pydantic_core_schema__(cls, source: Any, handler: GetCoreSchemaHandler) -> CoreSchema:
        schema = handler(source)
        _harden(schema, cls)
        return schema


class WorldConfig(Schema):
    """``[world]``: physics and run settings."""

    gravity: tuple[Gravity, Gravity, Gravity] = (0.0, 0.0, -9.81)
    time_step: float = Field(1.0 / 240.0, gt=0, le=0.1, description="physics step, seconds")
    solver_iterations: int = Field(50, ge=1, le=1000)
    seed: int = Field(0, ge=0, le=2**63 - 1)
    max_time: float = Field(60.0, gt=0, le=1e6, description="stop after this many sim seconds")
    max_wall_time: float | None = Field(None, gt=0, le=1e6,
                                        description="wall-clock budget in seconds (a watchdog: ends the run aborted)")
    gui: bool = False
    realtime: bool = Field(True, description="pace the GUI to wall-clock time (GUI only)")


class RegionConfig(Schema):
    """``[regions.NAME]``: a rectangle that bodies with ``region = NAME`` are scattered in, seeded."""

    model_config = ConfigDict(defer_build=True)  # built on first use: most configs have no regions

    low: tuple[Coord, Coord]
    high: tuple[Coord, Coord]
    z: Coord = 0.0
    min_spacing: float = Field(0.0, ge=0, le=1e3)
    avoid: tuple[str, ...] = ()
    clearance: float = Field(0.0, ge=0, le=1e3)

    @model_validator(mode="after")
    def _ordered(self) -> RegionConfig:
        if self.low[0] > self.high[0] or self.low[1] > self.high[1]:
            raise ValueError(f"low {list(self.low)} must be <= high {list(self.high)}")
        return self


def check_unit_colour(value: Any) -> Any:
    """A before-validator for colours: components above 1 are refused, with the 0-1 equivalent when they look like
    0-255 values (the per-component checks follow: finite, 0 to 1)."""
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                and math.isfinite(v) for v in value):
        if any(v > 1 for v in value):
            hint = ""
            if all(0 <= v <= 255 for v in value):
                hint = f" (for 0-255 values write [{', '.join(f'{v / 255:.3g}' for v in value)}])"
            raise ValueError(f"colour components must be 0-1 floats, got {list(value)}{hint}")
    return value


class MountConfig(Schema):
    """``mount = { body = "kuka", link = "lbr_iiwa_link_7", position = [0, 0, 0.05], rpy_deg = [0, 0, 0] }``.

    Fixes the body's base to ``body``'s ``link`` (its URDF link frame) with a fixed joint; ``position`` (metres)
    and ``rpy_deg`` place the mounted body's base frame in that link's frame.
    """

    model_config = ConfigDict(defer_build=True)  # its schema is part of BodyConfig's; its own validator on demand

    body: str
    link: str
    position: Position = (0.0, 0.0, 0.0)
    rpy_deg: tuple[Angle, Angle, Angle] = (0.0, 0.0, 0.0)
    max_force: float = Field(10_000.0, gt=0, le=1e9, description="N; how hard the joint holds")


class BodyConfig(Schema):
    """``[bodies.NAME]`` and ``[robots.NAME]``: a primitive (``shape``) or a URDF (``urdf``)."""

    shape: Literal["box", "sphere", "cylinder"] | None = None
    urdf: str | None = Field(None, min_length=1)
    sdf: str | None = Field(None, min_length=1, description="an SDF file (each model in it a body: NAME, NAME_1, ...)")
    mjcf: str | None = Field(None, min_length=1, description="a MuJoCo MJCF file, as far as pybullet's loader reads it")
    mount: MountConfig | None = Field(None, description="fix this body's base to another body's link")
    size: tuple[Length, Length, Length] = Field((0.1, 0.1, 0.1), description="box edge lengths, metres")
    radius: Length = 0.05
    height: Length = 0.1
    mass: float = Field(1.0, ge=0, le=1e6, description="kg; 0 = static")
    position: Position | None = None
    region: str | None = None
    rpy_deg: tuple[Angle, Angle, Angle] | None = None
    quaternion: Vec4 | None = Field(None, description="x, y, z, w (normalised on load)")
    yaw_deg_range: tuple[Angle, Angle] | None = None
    fixed_base: bool = False
    scale: float = Field(1.0, gt=0, le=1e3)
    rgba: tuple[Unit, Unit, Unit, Unit] = Field((0.7, 0.7, 0.7, 1.0), description="red, green, blue, alpha in 0-1")
    lateral_friction: float | None = Field(None, ge=0, le=100)
    rolling_friction: float | None = Field(None, ge=0, le=100)
    spinning_friction: float | None = Field(None, ge=0, le=100)
    restitution: float | None = Field(None, ge=0, le=1)
    linear_damping: float | None = Field(None, ge=0, le=1)
    angular_damping: float | None = Field(None, ge=0, le=1)
    joint_positions: dict[str, Annotated[float, Field(ge=-1e3, le=1e3)]] = Field(default_factory=dict)
    count: int = Field(1, ge=1, le=10_000)
    self_collision: bool = False
    collision: Literal["convex", "mesh"] = Field(
        "convex", description="'mesh': a static box's collision shape as triangles (cheaper for lidar rays)")

    @field_validator("rgba", mode="before")
    @classmethod
    def _unit_colour(cls, value: Any) -> Any:
        return check_unit_colour(value)

    @model_validator(mode="after")
    def _one_kind(self) -> BodyConfig:
        kinds = [k for k in ("shape", "urdf", "sdf", "mjcf") if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError("give exactly one of 'shape' (box, sphere, cylinder), 'urdf', 'sdf' or 'mjcf'"
                             + (f", not {' and '.join(kinds)}" if kinds else ""))
        if self.mount is not None:
            if self.region is not None or self.count > 1:
                raise ValueError("a mounted body takes its pose from 'mount': no 'region' or 'count'")
            if self.position is not None or self.rpy_deg is not None or self.quaternion is not None:
                raise ValueError("a mounted body is placed by 'mount.position' / 'mount.rpy_deg', not "
                                 "'position' / 'rpy_deg' / 'quaternion'")
        elif self.position is None and self.region is None:
            raise ValueError("give 'position' or 'region'")
        if self.rpy_deg is not None and self.quaternion is not None:
            raise ValueError("give 'rpy_deg' or 'quaternion', not both")
        if self.quaternion is not None and math.isclose(sum(v * v for v in self.quaternion), 0.0):
            raise ValueError("'quaternion' must not be all zeros")
        if self.yaw_deg_range is not None and self.yaw_deg_range[0] > self.yaw_deg_range[1]:
            raise ValueError(f"yaw_deg_range {list(self.yaw_deg_range)}: the first value must be <= the second")
        if self.collision == "mesh" and (self.shape != "box" or self.mass != 0):
            raise ValueError("collision = 'mesh' is for static boxes only (shape = 'box', mass = 0)")
        if self.count > 1 and self.region is None:
            raise ValueError("'count' > 1 needs a 'region' to scatter the copies in")
        return self


class EventConfig(Schema):
    """``[[events]]``: something done to the world at a sim time (lesson 01's push).

    ``force``: apply ``force`` (N, world frame) for ``duration`` seconds (default one step);
    ``set_pose``: teleport ``body`` to ``position`` (and ``rpy_deg``); ``remove``: delete ``body``.
    """

    model_config = ConfigDict(defer_build=True)  # built on first use: most configs have no events

    at: float = Field(ge=0, le=1e6, description="sim seconds")
    type: Literal["force", "set_pose", "remove"]
    body: str
    force: tuple[Newtons, Newtons, Newtons] | None = None
    duration: float = Field(0.0, ge=0, le=1e6)
    position: Position | None = None
    rpy_deg: tuple[Angle, Angle, Angle] | None = None

    @model_validator(mode="after")
    def _fields(self) -> EventConfig:
        if self.type == "force" and self.force is None:
            raise ValueError("a 'force' event needs 'force' = [fx, fy, fz] in newtons")
        if self.type == "set_pose" and self.position is None:
            raise ValueError("a 'set_pose' event needs 'position' = [x, y, z]")
        return self


class ReportConfig(Schema):
    """``[report]``: who the run is for, and one sub-table per reporter (``[report.local]``, ``[report.http]``)."""

    model_config = ConfigDict(extra="allow", frozen=True)
    student: str | None = None
    project: str | None = None
    keep_local: bool = Field(True, description="always add the local reporter")


class RecordConfig(Schema):
    """``[record]``: what a ``robokit run`` keeps in its run folder besides the result and the trace."""

    pose_hz: float = Field(30.0, ge=0, description="pose log samples per sim second; 0 = no pose log")
    save_frames: bool = Field(False, description="every camera saves the frames it renders as PNGs")


class GuiConfig(Schema):
    """``[gui]``: the PyBullet window's camera and panels (used with ``--gui`` only)."""

    distance: float = Field(1.6, gt=0, description="camera distance from the target, metres")
    yaw: float = Field(45.0, description="degrees")
    pitch: float = Field(-35.0, ge=-89.9, le=89.9, description="degrees")
    target: Vec3 | None = Field(None, description="point looked at (world, metres); default: the scene's centre")
    panels: bool = Field(False, description="show PyBullet's side panels (sliders, camera previews)")
    shadows: bool | None = Field(None, description="shadows on/off (default: PyBullet's own setting)")


@dataclass(frozen=True)
class ComponentSpec:
    """A validated plugin section: ``name`` (its key), ``type``, ``rate_hz`` (None = every tick), ``params``."""

    kind: str
    name: str
    type: str
    rate_hz: float | None
    params: Any
    key: str
    children: tuple[ComponentSpec, ...] = ()
    """The steps of a ``sequence`` behaviour (``[[behaviour.steps]]``), each a behaviour section of its own."""


@dataclass(frozen=True)
class Config:
    """A whole validated config. ``source`` is the file (or ``"<dict>"``); ``base_dir`` resolves relative paths."""

    source: str
    base_dir: Path
    world: WorldConfig
    regions: Mapping[str, RegionConfig]
    bodies: Mapping[str, BodyConfig]
    robots: Mapping[str, BodyConfig]
    sensors: tuple[ComponentSpec, ...]
    actuators: tuple[ComponentSpec, ...]
    behaviour: ComponentSpec | None
    report: ReportConfig
    reporters: tuple[ComponentSpec, ...]
    events: tuple[EventConfig, ...]
    raw: Mapping[str, Any]
    monitors: tuple[ComponentSpec, ...] = ()
    """Behaviours that run beside the task (``[monitors.NAME]``), see :mod:`robokit.compose`."""
    record: RecordConfig = field(default_factory=lambda: RecordConfig.model_validate({}))
    gui: GuiConfig = field(default_factory=lambda: GuiConfig.model_validate({}))


SECTIONS = ("world", "regions", "bodies", "robots", "sensors", "actuators", "behaviour", "monitors", "report",
            "events", "record", "gui", "env")
"""``env`` is read by :mod:`robokit.gym` (a Gymnasium environment made from the config); runs ignore it."""
_COMPONENT_KEYS = ("type", "rate_hz")


def read_toml(path: str | Path) -> dict[str, Any]:
    """Parse a TOML config file.

    Raises:
        ConfigError: One line naming the file: missing, a folder, unreadable, too large, not UTF-8 text (a binary
            file), a TOML syntax error, or empty (nothing but comments).
    """
    path = Path(path)
    data = _read_bytes(path)
    if b"\x00" in data:
        raise ConfigError("not a text file (it contains NUL bytes): a config is a TOML text file", file=str(path))
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise ConfigError(f"not UTF-8 text (byte 0x{data[exc.start]:02x} on line {line}): save the file as UTF-8",
                          file=str(path)) from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"TOML syntax error: {' '.join(str(exc).split())}", file=str(path)) from None
    if not raw:
        raise ConfigError("the file is empty (no tables, only comments or blank lines): nothing to run",
                          file=str(path))
    return raw


def _read_bytes(path: Path) -> bytes:
    try:
        if path.is_dir():
            raise ConfigError("is a folder, not a config file", file=str(path))
        size = path.stat().st_size
        if size > MAX_CONFIG_BYTES:
            raise ConfigError(f"too large for a config ({size} bytes; the limit is {MAX_CONFIG_BYTES})",
                              file=str(path))
        with path.open("rb") as fh:
            data = fh.read(MAX_CONFIG_BYTES + 1)  # a growing file or a device (/dev/zero) stops here
    except FileNotFoundError:
        raise ConfigError("file not found", file=str(path)) from None
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=str(path)) from None
    if len(data) > MAX_CONFIG_BYTES:
        raise ConfigError(f"too large for a config (over {MAX_CONFIG_BYTES} bytes)", file=str(path))
    return data


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def validation_error(exc: ValidationError, prefix: str = "") -> ConfigError:
    """Turn the first pydantic error into a one-line ConfigError at ``prefix.loc``."""
    err = exc.errors()[0]
    loc = [str(part) for part in err["loc"]]
    key = ".".join([prefix, *loc] if prefix else loc)
    if err["type"] == "extra_forbidden":
        fields = getattr(exc, "_robokit_fields", None) or []
        msg = f"unknown key {loc[-1]!r}{did_you_mean(loc[-1], fields)}"
        if fields:
            msg += f"; valid keys: {', '.join(sorted(fields))}"
        return ConfigError(msg, key=key)
    if err["type"] == "missing" and loc and loc[-1].isdigit():
        key = key.rsplit(".", 1)[0]
        return ConfigError(f"too few values, got {_describe(err.get('input'))}", key=key)
    msg = str(err["msg"]).replace("a valid tuple", "a list").replace("a valid dictionary", "a table")
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if err["type"] not in ("value_error", "missing", "assertion_error"):
        msg = f"{msg[0].lower()}{msg[1:]}, got {_describe(err.get('input'))}"
    return ConfigError(msg, key=key)


def validate_model(model: type[BaseModel], data: Any, key: str) -> Any:
    """Validate ``data`` against a pydantic model; raise a one-line ConfigError placed at ``key``."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"expected a table, got {_describe(data)}", key=key)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        fields = _nested_fields(model, exc)
        exc._robokit_fields = fields  # type: ignore[attr-defined]
        raise validation_error(exc, key) from None


def _nested_fields(model: type[BaseModel], exc: ValidationError) -> list[str]:
    """Field names of the (possibly nested) model an unknown-key error is about."""
    loc = exc.errors()[0]["loc"][:-1]
    current: Any = model
    for part in loc:
        field = getattr(current, "model_fields", {}).get(part)
        if field is None:
            return list(getattr(current, "model_fields", {}))
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            current = ann
    return list(getattr(current, "model_fields", {}))


def _table(raw: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    value = raw.get(name, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"expected a table [{name}], got {_describe(value)}", key=name)
    return value


def _rate(value: Any, key: str, physics_hz: float) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"expected a positive, finite number of Hz, got {_describe(value)}", key=key)
    ratio = physics_hz / value
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
        raise ConfigError(
            f"rate {value} Hz does not divide the physics rate {physics_hz:g} Hz "
            f"(use {physics_hz:g}/n, e.g. {physics_hz / 2:g}, {physics_hz / 4:g}, {physics_hz / 8:g})",
            key=key,
        )
    return float(value)


def _component(kind: str, name: str, data: Any, key: str, plugins: Any, physics_hz: float) -> ComponentSpec:
    if not isinstance(data, Mapping):
        raise ConfigError(f"expected a table, got {_describe(data)}", key=key)
    if "type" not in data:
        raise ConfigError(f"missing 'type' (the {kind} type to use)", key=key)
    type_name = data["type"]
    if not isinstance(type_name, str):
        raise ConfigError(f"expected a type name string, got {_describe(type_name)}", key=f"{key}.type")
    try:
        ptype = plugins.get(kind, type_name)
    except UserError as exc:
        raise ConfigError(str(exc), key=f"{key}.type") from None
    rate = _rate(data.get("rate_hz"), f"{key}.rate_hz", physics_hz)
    params_raw = {k: v for k, v in data.items() if k not in _COMPONENT_KEYS}
    if ptype.schema is None:
        if params_raw:
            extra = next(iter(params_raw))
            raise ConfigError(f"unknown key {extra!r}; {kind} type {type_name!r} takes no options", key=key)
        params = None
    else:
        params = validate_model(ptype.schema, params_raw, key)
    return ComponentSpec(kind, name, type_name, rate, params, key)


def _components(raw: Mapping[str, Any], section: str, kind: str, plugins: Any, physics_hz: float) -> tuple:
    return tuple(
        _component(kind, name, data, f"{section}.{name}", plugins, physics_hz)
        for name, data in _table(raw, section).items()
    )


def _reporters(report: Mapping[str, Any], plugins: Any) -> tuple[ComponentSpec, ...]:
    specs = []
    for name, data in report.items():
        if name in ReportConfig.model_fields:
            continue
        if not isinstance(data, Mapping):
            valid = sorted(set(ReportConfig.model_fields) | set(plugins.types["reporter"]))
            raise ConfigError(f"unknown key {name!r}{did_you_mean(name, valid)}; valid keys: {', '.join(valid)}",
                              key=f"report.{name}")
        try:
            ptype = plugins.get("reporter", name)
        except UserError as exc:
            raise ConfigError(str(exc), key=f"report.{name}") from None
        params = validate_model(ptype.schema, data, f"report.{name}") if ptype.schema else None
        specs.append(ComponentSpec("reporter", name, name, None, params, f"report.{name}"))
    keep_local = report.get("keep_local", True)
    if keep_local and "local" not in report and "local" in plugins.types["reporter"]:
        schema = plugins.types["reporter"]["local"].schema
        specs.insert(0, ComponentSpec("reporter", "local", "local", None, schema() if schema else None, "report.local"))
    return tuple(specs)


def _check_names(raw: Mapping[str, Any]) -> None:
    unknown = [k for k in raw if k not in SECTIONS]
    if unknown:
        name = unknown[0]
        raise ConfigError(
            f"unknown section {name!r}{did_you_mean(name, SECTIONS)}; valid sections: {', '.join(SECTIONS)}",
            key=name,
        )
    for group in (("bodies", "robots"), ("sensors", "actuators")):
        names: dict[str, str] = {}
        for section in group:
            for name in _table(raw, section):
                if name in names:
                    raise ConfigError(f"name {name!r} is already used in [{names[name]}]", key=f"{section}.{name}")
                names[name] = section


def build_config(
    raw: Mapping[str, Any], plugins: Any, *, source: str = "<dict>", base_dir: Path | None = None
) -> Config:
    """Validate a parsed config (a dict as TOML gives it) into a frozen :class:`Config`.

    Raises:
        ConfigError: The first problem found, as one line naming ``source`` and the key path.
    """
    try:
        return _build(raw, plugins, source, base_dir or Path("."))
    except ConfigError as exc:
        raise exc.within(file=source) from None


def _build(raw: Mapping[str, Any], plugins: Any, source: str, base_dir: Path) -> Config:
    _check_names(raw)
    world = validate_model(WorldConfig, _table(raw, "world"), "world")
    regions = {n: validate_model(RegionConfig, d, f"regions.{n}") for n, d in _table(raw, "regions").items()}
    bodies = {n: validate_model(BodyConfig, d, f"bodies.{n}") for n, d in _table(raw, "bodies").items()}
    robots = {n: validate_model(BodyConfig, d, f"robots.{n}") for n, d in _table(raw, "robots").items()}
    for section, group in (("bodies", bodies), ("robots", robots)):
        for name, body in group.items():
            if body.region is not None and body.region not in regions:
                raise ConfigError(
                    f"unknown region {body.region!r}{did_you_mean(body.region, regions)}; "
                    f"defined: {', '.join(regions) or '(none)'}",
                    key=f"{section}.{name}.region",
                )
    physics_hz = 1.0 / world.time_step
    sensors = _components(raw, "sensors", "sensor", plugins, physics_hz)
    actuators = _components(raw, "actuators", "actuator", plugins, physics_hz)
    behaviour = None
    if "behaviour" in raw:
        behaviour = _behaviour(raw["behaviour"], plugins, physics_hz)
    for name, data in _table(raw, "monitors").items():
        if isinstance(data, Mapping) and data.get("type") == "sequence":
            raise ConfigError("a monitor cannot be a sequence (monitors observe beside the task)",
                              key=f"monitors.{name}")
    monitors = _components(raw, "monitors", "behaviour", plugins, physics_hz)
    report_raw = _table(raw, "report")
    report = validate_model(ReportConfig, {k: v for k, v in report_raw.items() if k in ReportConfig.model_fields},
                            "report")
    reporters = _reporters(report_raw, plugins)
    events_raw = raw.get("events", [])
    if not isinstance(events_raw, list):
        raise ConfigError("expected an array of tables [[events]]", key="events")
    events = tuple(validate_model(EventConfig, e, f"events[{i}]") for i, e in enumerate(events_raw))
    all_bodies = set(bodies) | set(robots)
    for i, event in enumerate(events):
        if event.body not in all_bodies and not any(event.body.startswith(f"{b}_") for b in all_bodies):
            raise ConfigError(
                f"unknown body {event.body!r}{did_you_mean(event.body, all_bodies)}", key=f"events[{i}].body"
            )
    if not (bodies or robots or behaviour or sensors or actuators):
        raise ConfigError("nothing to run: the config has no [bodies], [robots] or [behaviour]")
    record = validate_model(RecordConfig, _table(raw, "record"), "record")
    gui = validate_model(GuiConfig, _table(raw, "gui"), "gui")
    return Config(source, base_dir, world, regions, bodies, robots, sensors, actuators, behaviour, report,
                  reporters, events, copy.deepcopy(dict(raw)), monitors, record, gui)


def _behaviour(data: Any, plugins: Any, physics_hz: float) -> ComponentSpec:
    """The ``[behaviour]`` section; for ``type = "sequence"`` also its ``[[behaviour.steps]]``, each validated as a
    behaviour section of its own (with an optional ``name``)."""
    if not (isinstance(data, Mapping) and data.get("type") == "sequence"):
        return _component("behaviour", "behaviour", data, "behaviour", plugins, physics_hz)
    from robokit.compose import step_names

    steps = data.get("steps")
    if not isinstance(steps, list) or not steps or not all(isinstance(s, Mapping) for s in steps):
        raise ConfigError("a sequence needs steps: one or more [[behaviour.steps]] tables, each with a type",
                          key="behaviour.steps")
    names = step_names(steps)
    children = []
    for i, (step, name) in enumerate(zip(steps, names, strict=True)):
        key = f"behaviour.steps[{i}]"
        if step.get("type") == "sequence":
            raise ConfigError("a sequence step cannot itself be a sequence", key=f"{key}.type")
        if names.count(name) > 1:
            raise ConfigError(f"two steps are named {name!r}; give each a distinct name", key=f"{key}.name")
        own = {k: v for k, v in step.items() if k != "name"}
        children.append(_component("behaviour", name, own, key, plugins, physics_hz))
    spec = _component("behaviour", "behaviour", {k: v for k, v in data.items() if k != "steps"}, "behaviour",
                      plugins, physics_hz)
    return dataclasses.replace(spec, children=tuple(children))


def load_config(path: str | Path, plugins: Any, overrides: Mapping[str, Any] | None = None) -> Config:
    """Read and validate a TOML config file. ``overrides`` maps dotted keys to values (CLI options)."""
    raw = read_toml(path)
    for dotted, value in (overrides or {}).items():
        set_dotted(raw, dotted, value)
    return build_config(raw, plugins, source=str(path), base_dir=Path(path).resolve().parent)


def set_dotted(raw: dict[str, Any], dotted: str, value: Any) -> None:
    """Set ``raw["a"]["b"] = value`` for ``dotted = "a.b"``, creating tables on the way."""
    *parents, last = dotted.split(".")
    node = raw
    for i, part in enumerate(parents):
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            where = ".".join(parents[: i + 1])
            raise ConfigError(f"expected a table to set {last!r} in, got {_describe(node)}", key=where)
    node[last] = value
