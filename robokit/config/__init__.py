"""TOML in, frozen typed objects out.

Every problem is a :class:`~robokit.errors.ConfigError` whose text is one line: the file, the key path, and what
was expected against what was found. Unknown keys are errors with a "did you mean". Plugin sections are validated
by the schema their type registered.

Lives here: the loader (this module: ``load``, ``Config`` and the core sections' schemas), ``sections`` (the light
schema classes every core section and most plugins use, and the one-line error they raise) and ``schema``
(``robokit.config.Schema``, the pydantic base for plugin schemas, imported only when a plugin uses it).

May import: ``robokit.errors`` and the standard library; pydantic only in ``schema``. The plugin registries are
handed in by the caller, so configuration never imports the loop, the plugin manager or a reporter.
"""

import copy
import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from robokit.config import sections as _s
from robokit.config.randomize import RandomizeConfig as RandomizeConfig
from robokit.config.sections import (
    FLOAT_LIMIT as FLOAT_LIMIT,  # re-exported: every float within ±FLOAT_LIMIT by default
)
from robokit.config.sections import Invalid, Section, field_names, setting
from robokit.config.sections import describe_value as _describe
from robokit.config.sections import error_from_parts as error_from_parts  # re-exported
from robokit.errors import ConfigError, UserError, did_you_mean

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

if TYPE_CHECKING:  # at run time these come from robokit.config.schema on first use (see __getattr__)
    from robokit.config.schema import Angle as Angle
    from robokit.config.schema import Coord as Coord
    from robokit.config.schema import Gravity as Gravity
    from robokit.config.schema import Length as Length
    from robokit.config.schema import Newtons as Newtons
    from robokit.config.schema import Position as Position
    from robokit.config.schema import Schema as Schema
    from robokit.config.schema import Unit as Unit
    from robokit.config.schema import validation_error as validation_error

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
Vec4 = tuple[float, float, float, float]

MAX_CONFIG_BYTES = 4 * 1024 * 1024
"""A config file larger than this is refused unread (a config is a few kilobytes of TOML)."""

_PYDANTIC_NAMES = frozenset({"Schema", "validation_error", "Coord", "Angle", "Unit", "Length", "Position",
                             "Gravity", "Newtons"})


def __getattr__(name: str) -> Any:
    """``Schema``, ``validation_error`` and the pydantic field types, imported from
    :mod:`robokit.config.schema` when first asked for: importing this module does not import pydantic."""
    if name in _PYDANTIC_NAMES:
        from robokit.config import schema as pydantic_schema

        return getattr(pydantic_schema, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class WorldConfig(Section):
    """``[world]``: physics and run settings."""

    gravity: tuple[_s.Gravity, _s.Gravity, _s.Gravity] = (0.0, 0.0, -9.81)
    time_step: float = setting(1.0 / 240.0, gt=0, le=0.1, description="physics step, seconds")
    solver_iterations: int = setting(50, ge=1, le=1000, description="constraint solver iterations per physics step")
    seed: int = setting(0, ge=0, le=2**63 - 1, description="the run's random seed (scattered bodies, sensor noise); "
                                                         "--seed overrides it")
    max_time: float = setting(60.0, gt=0, le=1e6, description="stop after this many sim seconds")
    max_wall_time: float | None = setting(None, gt=0, le=1e6,
                                          description="wall-clock budget in seconds (a watchdog: ends the run "
                                                      "aborted)")
    gui: bool = setting(False, description="open the PyBullet window (as --gui does)")
    realtime: bool = setting(True, description="pace the GUI to wall-clock time (GUI only)")
    engine: Literal["pybullet", "mujoco"] = setting("pybullet", description="physics engine (--engine overrides it; "
                                                                          "mujoco needs robokit[mujoco])")


class RegionConfig(Section):
    """``[regions.NAME]``: a rectangle that bodies with ``region = NAME`` are scattered in, seeded."""

    low: tuple[_s.Coord, _s.Coord] = setting()
    high: tuple[_s.Coord, _s.Coord] = setting()
    z: _s.Coord = 0.0
    min_spacing: float = setting(0.0, ge=0, le=1e3, description="metres between scattered bodies' centres")
    avoid: tuple[str, ...] = setting((), description="bodies the scattered ones keep clear of")
    clearance: float = setting(0.0, ge=0, le=1e3, description="metres kept clear around the avoided bodies")

    def check(self) -> None:
        """``low`` is below ``high`` on both axes."""
        if self.low[0] > self.high[0] or self.low[1] > self.high[1]:
            raise ValueError(f"low {list(self.low)} must be <= high {list(self.high)}")


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


class MountConfig(Section):
    """``mount = { body = "kuka", link = "lbr_iiwa_link_7", position = [0, 0, 0.05], rpy_deg = [0, 0, 0] }``.

    Fixes the body's base to ``body``'s ``link`` (its URDF link frame) with a fixed joint; ``position`` (metres)
    and ``rpy_deg`` place the mounted body's base frame in that link's frame.
    """

    body: str = setting(description="the body to mount on")
    link: str = setting(description="its link, by name")
    position: _s.Position = setting((0.0, 0.0, 0.0), description="metres, in that link's frame")
    rpy_deg: tuple[_s.Angle, _s.Angle, _s.Angle] = setting((0.0, 0.0, 0.0), description="degrees, in that link's frame")
    max_force: float = setting(10_000.0, gt=0, le=1e9, description="N; how hard the joint holds")


class BodyConfig(Section):
    """``[bodies.NAME]`` and ``[robots.NAME]``: a primitive (``shape``) or a URDF (``urdf``)."""

    shape: Literal["box", "sphere", "cylinder"] | None = setting(None, description="a primitive: box (size), sphere "
                                                                  "(radius) or cylinder (radius, height)")
    urdf: str | None = setting(None, min_length=1, description="a URDF file (relative to the config, a bundled "
                                                               "robot or a pybullet_data name)")
    sdf: str | None = setting(None, min_length=1, description="an SDF file (each model in it a body: NAME, NAME_1, "
                                                              "...)")
    mjcf: str | None = setting(None, min_length=1, description="a MuJoCo MJCF file, as far as pybullet's loader "
                                                               "reads it")
    xacro_args: dict[str, Any] = setting(
        default_factory=dict, description="with urdf = \"x.urdf.xacro\": the xacro arguments (name -> value)")
    mount: MountConfig | None = setting(None, description="fix this body's base to another body's link")
    size: tuple[_s.Length, _s.Length, _s.Length] = setting((0.1, 0.1, 0.1), description="box edge lengths, metres")
    radius: _s.Length = 0.05
    height: _s.Length = 0.1
    mass: float = setting(1.0, ge=0, le=1e6, description="kg; 0 = static")
    position: _s.Position | None = None
    region: str | None = setting(None, description="scatter in this [regions.NAME] (instead of position)")
    rpy_deg: tuple[_s.Angle, _s.Angle, _s.Angle] | None = None
    quaternion: Vec4 | None = setting(None, description="x, y, z, w (normalised on load)")
    yaw_deg_range: tuple[_s.Angle, _s.Angle] | None = None
    fixed_base: bool = setting(False, description="pin the base in place")
    scale: float = setting(1.0, gt=0, le=1e3, description="model scale factor (urdf, sdf)")
    rgba: tuple[_s.Unit, _s.Unit, _s.Unit, _s.Unit] = setting((0.7, 0.7, 0.7, 1.0), before=check_unit_colour,
                                                              description="red, green, blue, alpha in 0-1")
    lateral_friction: float | None = setting(None, ge=0, le=100)
    rolling_friction: float | None = setting(None, ge=0, le=100)
    spinning_friction: float | None = setting(None, ge=0, le=100)
    restitution: float | None = setting(None, ge=0, le=1, description="bounciness: 0 = none, 1 = no energy lost")
    linear_damping: float | None = setting(None, ge=0, le=1)
    angular_damping: float | None = setting(None, ge=0, le=1)
    joint_positions: dict[str, Annotated[float, _s.Bounds(ge=-1e3, le=1e3)]] = setting(
        default_factory=dict, description="joint name -> start position (rad, or m for a sliding joint)")
    count: int = setting(1, ge=1, le=10_000, description="copies: 1 is one body named NAME; N > 1 are NAME_0 .. "
                                                         "NAME_{N-1}, scattered in region")
    self_collision: bool = setting(False, description="the body's links collide with each other")
    collision: Literal["convex", "mesh"] = setting(
        "convex", description="'mesh': a static box's collision shape as triangles (cheaper for lidar rays)")

    def check(self) -> None:
        """One kind of body; a pose from exactly one source; orientation, yaw range, mesh and count consistent."""
        self._one_kind()

    def _one_kind(self) -> None:
        kinds = [k for k in ("shape", "urdf", "sdf", "mjcf") if getattr(self, k) is not None]
        if len(kinds) != 1:
            raise ValueError("give exactly one of 'shape' (box, sphere, cylinder), 'urdf', 'sdf' or 'mjcf'"
                             + (f", not {' and '.join(kinds)}" if kinds else ""))
        self._key_matches_file(kinds[0])
        if self.xacro_args and not (self.urdf or "").lower().endswith(".xacro"):
            raise ValueError("'xacro_args' is for a xacro file: urdf = \"NAME.urdf.xacro\"")
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


    def _key_matches_file(self, key: str) -> None:
        """``urdf = "x.sdf"``: pybullet's URDF loader cannot read it; say which key reads that kind of file."""
        path = getattr(self, key)
        wanted = _MODEL_KEYS.get(Path(path).suffix.lower()) if key != "shape" else None
        if wanted is not None and wanted != key:
            raise ValueError(f'{key} = "{path}" is {"an" if wanted in ("sdf", "mjcf") else "a"} {wanted.upper()} '
                             f'file: the key for it is {wanted} = "{path}"')


_MODEL_KEYS = {".urdf": "urdf", ".sdf": "sdf", ".xml": "mjcf", ".mjcf": "mjcf"}
MODEL_FILE_KEYS = ("urdf", "sdf", "mjcf")
"""The keys of a body or robot that name a file (what a course submission may set only to a packaged model)."""


class EventConfig(Section):
    """``[[events]]``: something done to the world at a sim time (lesson 01's push).

    ``force``: apply ``force`` (N, world frame) for ``duration`` seconds (default one step);
    ``set_pose``: teleport ``body`` to ``position`` (and ``rpy_deg``); ``remove``: delete ``body``.
    """

    at: float = setting(ge=0, le=1e6, description="sim seconds")
    type: Literal["force", "set_pose", "remove"] = setting()
    body: str = setting(description="the body acted on")
    force: tuple[_s.Newtons, _s.Newtons, _s.Newtons] | None = None
    duration: float = setting(0.0, ge=0, le=1e6, description="seconds the force lasts (0 = one physics step)")
    position: _s.Position | None = None
    rpy_deg: tuple[_s.Angle, _s.Angle, _s.Angle] | None = None

    def check(self) -> None:
        """A ``force`` event has a force, a ``set_pose`` event a position."""
        if self.type == "force" and self.force is None:
            raise ValueError("a 'force' event needs 'force' = [fx, fy, fz] in newtons")
        if self.type == "set_pose" and self.position is None:
            raise ValueError("a 'set_pose' event needs 'position' = [x, y, z]")


class ReportConfig(Section):
    """``[report]``: who the run is for, and one sub-table per reporter (``[report.local]``, ``[report.http]``)."""

    ignore_unknown = True
    student: str | None = setting(None, description="who the run is for (sent with the result)")
    project: str | None = setting(None, description="the course project (sent with the result)")
    keep_local: bool = setting(True, description="always add the local reporter")


class RecordConfig(Section):
    """``[record]``: what a ``robokit run`` keeps in its run folder besides the result and the trace."""

    pose_hz: float = setting(30.0, ge=0, description="pose log samples per sim second; 0 = no pose log")
    save_frames: bool = setting(False, description="every camera saves the frames it renders as PNGs")


class GuiConfig(Section):
    """``[gui]``: the PyBullet window's camera and panels (used with ``--gui`` only)."""

    distance: float = setting(1.6, gt=0, description="camera distance from the target, metres")
    yaw: float = setting(45.0, description="degrees")
    pitch: float = setting(-35.0, ge=-89.9, le=89.9, description="degrees")
    target: Vec3 | None = setting(None, description="point looked at (world, metres); default: the scene's centre")
    panels: bool = setting(False, description="show PyBullet's side panels (sliders, camera previews)")
    shadows: bool | None = setting(None, description="shadows on/off (default: PyBullet's own setting)")


@dataclass(frozen=True)
class ComponentSpec:
    """A validated plugin section: ``name`` (its key), ``type``, ``rate_hz`` (None = every tick), ``params``."""

    kind: str
    name: str
    type: str
    rate_hz: float | None
    params: Any
    key: str
    action: str = "observe"
    """Monitors only: what the monitor's ending ``failed`` or ``aborted`` does to the task: ``observe`` (nothing),
    ``abort`` (the run ends aborted, actuators brought to a protective stop) or ``recover`` (the task is halted,
    actuators stopped, and the ``[recoveries.NAME]`` behaviour named by ``recovery`` takes over)."""
    recovery: str | None = None
    watch_recovery: bool = True
    """Monitors only: after pre-empting the task (``action = "recover"``), a fresh instance of the monitor keeps
    watching the recovery; if it trips too, the run ends ``aborted`` with a protective stop in that tick."""
    must_last: bool = False
    """Children of composites only: the child's goal, judged when it ended, is asked of the world again when the
    run ends (the last step of a sequence, and the child that decided any other composite, always are)."""
    children: tuple["ComponentSpec", ...] = ()
    """The children of a composite behaviour (a sequence's ``[[behaviour.steps]]``, a fallback's
    ``[[behaviour.children]]``, a retry's ``[behaviour.child]``...), each a behaviour section of its own."""


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
    """Behaviours that run beside the task (``[monitors.NAME]``), see :mod:`robokit.core.compose`."""
    recoveries: Mapping[str, ComponentSpec] = field(default_factory=dict)
    """Behaviours a monitor may pre-empt the task into (``[recoveries.NAME]``, named by a monitor's ``recovery``)."""
    record: RecordConfig = field(default_factory=RecordConfig)
    gui: GuiConfig = field(default_factory=GuiConfig)
    randomize: RandomizeConfig | None = None
    """``[randomize]``, None without one (see :mod:`robokit.core.randomize`)."""


SECTIONS = ("world", "regions", "bodies", "robots", "sensors", "actuators", "behaviour", "monitors", "recoveries",
            "report", "events", "record", "gui", "env", "randomize")
"""``env`` is read by :mod:`robokit.gym` (a Gymnasium environment made from the config); runs ignore it."""
_COMPONENT_KEYS = ("type", "rate_hz")
_REPORT_KEYS = field_names(ReportConfig)


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


def validate_model(model: type, data: Any, key: str) -> Any:
    """Validate ``data`` against a config schema, a light :class:`~robokit.config.sections.Section` or a pydantic model
    (only the latter imports pydantic); raise a one-line ConfigError placed at ``key``."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"expected a table, got {_describe(data)}", key=key)
    try:
        if isinstance(model, type) and issubclass(model, Section):
            try:
                return model.validate(data)
            except Invalid as exc:
                raise error_from_parts(exc.loc, exc.kind, exc.msg, exc.value, key, exc.fields) from None
        from robokit.config.schema import validate_pydantic

        return validate_pydantic(model, data, key)  # type: ignore[arg-type]
    except ConfigError as exc:
        raise _typo_behind(exc, model, data, key) from None


def _typo_behind(exc: ConfigError, model: Any, data: Mapping[str, Any], key: str) -> ConfigError:
    """``exc`` about a key the table lacks (``seconds: field required``, ``url: missing``) said as the misspelt key
    the table has instead (``secnds = 2``: unknown, did you mean 'seconds'); any other error as it is."""
    fields = field_names(model)
    about = exc.key[len(key) + 1:].split(".")[0] if exc.key.startswith(f"{key}.") else ""
    if getattr(model, "ignore_unknown", False) or about not in fields or about in data:
        return exc
    typo = next((k for k in data if k not in fields and did_you_mean(str(k), [about])), None)
    if typo is None:
        return exc
    return ConfigError(f"unknown key {typo!r}{did_you_mean(str(typo), fields)}; valid keys: "
                       f"{', '.join(sorted(fields))}", key=f"{key}.{typo}", file=exc.file)


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


def _component(kind: str, name: str, data: Any, key: str, plugins: Any, physics_hz: float,
               section_keys: tuple[str, ...] = _COMPONENT_KEYS) -> ComponentSpec:
    """A plugin section. ``section_keys``: the keys the section takes besides its type's own (``type``,
    ``rate_hz``; a composite's child's ``name`` and ``must_last``, a monitor's ``action`` ...), offered with the
    type's keys when a key is unknown."""
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
            provided = getattr(ptype, "provided", None)
            raise ConfigError(f"unknown key {extra!r}{did_you_mean(extra, section_keys)}; {kind} type {type_name!r} "
                              "takes no options"
                              + (provided() if provided else ""), key=key)
        params = None
    else:
        try:
            params = validate_model(ptype.schema, params_raw, key)
        except ConfigError as exc:  # name the distribution of a third-party type: a clash must never hide
            exc = _offer_section_keys(exc, ptype.schema, params_raw, key, section_keys)
            provided = getattr(ptype, "provided", None)
            raise ConfigError(exc.message + (provided() if provided else ""), key=exc.key, file=exc.file) from None
    return ComponentSpec(kind, name, type_name, rate, params, key)


def _offer_section_keys(exc: ConfigError, schema: Any, params: Mapping[str, Any], key: str,
                        section_keys: tuple[str, ...]) -> ConfigError:
    """An unknown key of a plugin section said again with the section's own keys among the valid ones (a misspelt
    ``rate_hz`` or ``must_last`` is suggested as well as the type's keys); any other error as it is."""
    unknown = exc.key[len(key) + 1:] if exc.key.startswith(f"{key}.") else ""
    if unknown not in params or not exc.message.startswith("unknown key"):
        return exc
    valid = sorted({*field_names(schema), *section_keys})
    return ConfigError(f"unknown key {unknown!r}{did_you_mean(unknown, valid)}; valid keys: {', '.join(valid)}",
                       key=exc.key, file=exc.file)


def _components(raw: Mapping[str, Any], section: str, kind: str, plugins: Any, physics_hz: float) -> tuple:
    return tuple(
        _component(kind, name, data, f"{section}.{name}", plugins, physics_hz)
        for name, data in _table(raw, section).items()
    )


def _reporters(report: Mapping[str, Any], plugins: Any) -> tuple[ComponentSpec, ...]:
    specs = []
    for name, data in report.items():
        if name in _REPORT_KEYS:
            continue
        if not isinstance(data, Mapping):
            if name in plugins.types["reporter"]:
                raise ConfigError(f"expected a table [report.{name}], got {_describe(data)}", key=f"report.{name}")
            valid = sorted(set(_REPORT_KEYS) | set(plugins.types["reporter"]))
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
        params = validate_model(schema, {}, "report.local") if schema else None
        specs.insert(0, ComponentSpec("reporter", "local", "local", None, params, "report.local"))
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
        if isinstance(data, Mapping) and _children_key(data.get("type"), plugins) is not None:
            raise ConfigError(f"a monitor cannot be a {data.get('type')} (monitors observe beside the task)",
                              key=f"monitors.{name}")
    recoveries = {name: _behaviour(data, plugins, physics_hz, f"recoveries.{name}", name)
                  for name, data in _table(raw, "recoveries").items()}
    monitors = tuple(_monitor(name, data, plugins, physics_hz, recoveries)
                     for name, data in _table(raw, "monitors").items())
    for spec in monitors:
        if spec.action != "observe" and behaviour is None:
            raise ConfigError(f"action {spec.action!r} acts on the task, and there is none: add a [behaviour]",
                              key=f"{spec.key}.action")
    report_raw = _table(raw, "report")
    report = validate_model(ReportConfig, {k: v for k, v in report_raw.items() if k in _REPORT_KEYS}, "report")
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
    randomize = _randomize(raw, all_bodies, sensors, actuators)
    return Config(source, base_dir, world, regions, bodies, robots, sensors, actuators, behaviour, report,
                  reporters, events, copy.deepcopy(dict(raw)), monitors, recoveries, record, gui, randomize)


def _randomize(raw: Mapping[str, Any], bodies: set[str], sensors: tuple[ComponentSpec, ...],
               actuators: tuple[ComponentSpec, ...]) -> RandomizeConfig | None:
    """``[randomize]`` validated, its body, sensor and setting names checked against the config's."""
    if "randomize" not in raw:
        return None
    spec: RandomizeConfig = validate_model(RandomizeConfig, _table(raw, "randomize"), "randomize")
    for i, name in enumerate(spec.bodies):
        if name not in bodies:
            raise ConfigError(f"unknown body {name!r}{did_you_mean(name, bodies)}; valid: {', '.join(sorted(bodies))}",
                              key=f"randomize.bodies[{i}]")
    names = [s.name for s in sensors]
    for name in spec.dropout:
        if name not in names:
            raise ConfigError(f"unknown sensor {name!r}{did_you_mean(name, names)}; sensors: "
                              f"{', '.join(names) or '(none)'}", key=f"randomize.dropout.{name}")
    components = {f"{s.kind}s.{s.name}": s for s in sensors + actuators}
    for dotted in spec.params:
        section, name, setting_ = dotted.split(".", 2)
        comp = components.get(f"{section}.{name}")
        if comp is None:
            valid = [k for k in components if k.startswith(section)]
            raise ConfigError(f"unknown {section[:-1]} {name!r}{did_you_mean(name, [v.split('.')[1] for v in valid])}"
                              f"; {section}: {', '.join(v.split('.')[1] for v in valid) or '(none)'}",
                              key=f"randomize.params.{dotted}")
        keys = field_names(type(comp.params)) if comp.params is not None else ()
        if setting_ not in keys:
            raise ConfigError(f"unknown setting {setting_!r}{did_you_mean(setting_, keys)} of {comp.type} "
                              f"{name!r}; valid: {', '.join(keys) or '(none)'}", key=f"randomize.params.{dotted}")
    return spec


def step_names(steps: Sequence[Mapping[str, Any]]) -> list[str]:
    """Names of sequence steps: the ``name`` key, else ``<type>`` (``<type>_<n>`` when unnamed steps share a type)."""
    unnamed = [str(s.get("type", "step")) for s in steps if not s.get("name")]
    names: list[str] = []
    seen: dict[str, int] = {}
    for step in steps:
        if step.get("name"):
            names.append(str(step["name"]))
            continue
        type_name = str(step.get("type", "step"))
        seen[type_name] = seen.get(type_name, 0) + 1
        names.append(type_name if unnamed.count(type_name) == 1 else f"{type_name}_{seen[type_name]}")
    return names


MONITOR_ACTIONS = ("observe", "abort", "recover")


def _monitor(name: str, data: Any, plugins: Any, physics_hz: float,
             recoveries: Mapping[str, ComponentSpec]) -> ComponentSpec:
    """A ``[monitors.NAME]`` section: a behaviour section plus ``action`` and ``recovery`` (read by the core)."""
    key = f"monitors.{name}"
    own = dict(data) if isinstance(data, Mapping) else data
    action, recovery, watch = "observe", None, True
    if isinstance(own, dict):
        action = own.pop("action", "observe")
        recovery = own.pop("recovery", None)
        watch = own.pop("watch_recovery", True)
        if not isinstance(watch, bool):
            raise ConfigError(f"expected true or false, got {_describe(watch)}", key=f"{key}.watch_recovery")
        if not watch and action != "recover":
            raise ConfigError(f"watch_recovery is used with action = 'recover' only (action is {action!r})",
                              key=f"{key}.watch_recovery")
        if action not in MONITOR_ACTIONS:
            raise ConfigError(f"expected one of {', '.join(repr(a) for a in MONITOR_ACTIONS)}, got "
                              f"{_describe(action)}", key=f"{key}.action")
        if recovery is not None and not isinstance(recovery, str):
            raise ConfigError(f"expected the name of a [recoveries.NAME] section, got {_describe(recovery)}",
                              key=f"{key}.recovery")
        if action == "recover" and recovery is None:
            raise ConfigError("action 'recover' needs recovery = the name of a [recoveries.NAME] section",
                              key=f"{key}.recovery")
        if recovery is not None and action != "recover":
            raise ConfigError(f"recovery is used with action = 'recover' only (action is {action!r})",
                              key=f"{key}.recovery")
        if recovery is not None and recovery not in recoveries:
            raise ConfigError(f"unknown recovery {recovery!r}{did_you_mean(recovery, recoveries)}; defined: "
                              f"{', '.join(recoveries) or '(none: add a [recoveries.NAME] section)'}",
                              key=f"{key}.recovery")
    spec = _component("behaviour", name, own, key, plugins, physics_hz,
                      (*_COMPONENT_KEYS, "action", "recovery", "watch_recovery"))
    return dataclasses.replace(spec, action=action, recovery=recovery, watch_recovery=watch)


def _children_key(type_name: Any, plugins: Any) -> tuple[str, tuple[int, int | None]] | None:
    """The config key holding a composite type's children and how many it takes (None: not a composite)."""
    try:
        cls = plugins.get("behaviour", type_name).cls if isinstance(type_name, str) else None
    except UserError:
        return None
    key = getattr(cls, "CHILDREN_KEY", None)
    return (key, getattr(cls, "ARITY", (1, None))) if isinstance(key, str) else None


def _behaviour(data: Any, plugins: Any, physics_hz: float, key: str = "behaviour",
               name: str = "behaviour", is_child: bool = False) -> ComponentSpec:
    """A behaviour section; for a composite (``sequence``, ``fallback``, ``retry``, ``timeout``, ``parallel``)
    also its children (``[[behaviour.steps]]``, ``[[behaviour.children]]`` or ``[behaviour.child]``), each
    validated as a behaviour section of its own (with an optional ``name``), composites nesting."""
    found = _children_key(data.get("type"), plugins) if isinstance(data, Mapping) else None
    section_keys = (*_COMPONENT_KEYS, "name", "must_last") if is_child else _COMPONENT_KEYS
    if found is None:
        return _component("behaviour", name, data, key, plugins, physics_hz, section_keys)
    ckey, (least, most) = found
    raw = data.get(ckey)
    single = most == 1 and isinstance(raw, Mapping)
    items = [raw] if single else raw
    what = f"[{key}.{ckey}] table" if most == 1 else f"[[{key}.{ckey}]] tables"
    if not isinstance(items, list) or not all(isinstance(s, Mapping) for s in items) or not (
            least <= len(items) <= (most if most is not None else len(items))):
        count = {(1, 1): "one", (1, None): "one or more"}.get((least, most), f"{least} or more")
        noun = "steps" if ckey == "steps" else ("a child" if most == 1 else "children")
        raise ConfigError(f"a {data.get('type')} needs {noun}: {count} {what}, each with a type",
                          key=f"{key}.{ckey}")
    for i, step in enumerate(items):
        given = step.get("name")
        if "name" in step and (not isinstance(given, str) or not given.strip()):
            raise ConfigError(f"expected a name (a non-empty string), got {_describe(given)}",
                              key=f"{key}.{ckey}.name" if single else f"{key}.{ckey}[{i}].name")
    names = step_names(items)
    children = []
    for i, (step, child_name) in enumerate(zip(items, names, strict=True)):
        child_key = f"{key}.{ckey}" if single else f"{key}.{ckey}[{i}]"
        if names.count(child_name) > 1:
            raise ConfigError(f"two steps are named {child_name!r}; give each a distinct name",
                              key=f"{child_key}.name")
        own = {k: v for k, v in step.items() if k not in ("name", "must_last")}
        must_last = step.get("must_last", False)
        if not isinstance(must_last, bool):
            raise ConfigError(f"expected true or false, got {_describe(must_last)}", key=f"{child_key}.must_last")
        child = _behaviour(own, plugins, physics_hz, child_key, child_name, is_child=True)
        children.append(dataclasses.replace(child, must_last=must_last))
    spec = _component("behaviour", name, {k: v for k, v in data.items() if k != ckey}, key, plugins, physics_hz,
                      (*section_keys, ckey))
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


def results_root(cfg: Config) -> Path:
    """Where run folders go: the local reporter's ``dir`` (``[report.local] dir``), default ``results``."""
    for spec in cfg.reporters:
        if spec.type == "local" and spec.params is not None and getattr(spec.params, "dir", None):
            return Path(spec.params.dir)
    return Path("results")
