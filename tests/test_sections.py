"""robokit's own validator for light schemas (:mod:`robokit.config.sections`): the core sections and the ``local``
reporter are validated without pydantic, with pydantic's rules and messages (``test_core_config_errors`` and the
bad-input corpus hold the user-facing lines); here, its edge cases and plugin types with a light schema."""

from __future__ import annotations

import dataclasses
import math
import types
from typing import Annotated, Any, Literal

import pytest

from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import (
    BodyConfig,
    Config,
    GuiConfig,
    MountConfig,
    RecordConfig,
    WorldConfig,
    build_config,
    validate_model,
)
from robokit.config.sections import Bounds, Section, field_names, setting
from robokit.errors import ConfigError
from robokit.plugin_api.plugins import load_plugins

PLANE = {"urdf": "plane.urdf", "position": [0, 0, 0]}


def refusal(schema: type, data: dict[str, Any], key: str = "x") -> str:
    with pytest.raises(ConfigError) as exc:
        validate_model(schema, data, key)
    text = str(exc.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize(("data", "expected"), [
    ({"time_step": True}, "x.time_step: input should be a valid number, got True"),
    ({"seed": True}, "x.seed: input should be a valid integer, got True"),
    ({"seed": 1.0}, "x.seed: input should be a valid integer, got 1.0"),
    ({"gui": 1}, "x.gui: input should be a valid boolean, got 1"),
    ({"gui": "no"}, "x.gui: input should be a valid boolean, got 'no'"),
    ({"gravity": [0, 0, True]}, "x.gravity.2: input should be a valid number, got True"),
    ({"time_step": math.nan}, "x.time_step: input should be a finite number, got nan"),
    ({"max_time": math.inf}, "x.max_time: input should be a finite number, got inf"),
    ({"gravity": [0, 0, -math.inf]}, "x.gravity.2: input should be a finite number, got -inf"),
    ({"gravity": [0, -9.81]}, "x.gravity: too few values, got [0, -9.81]"),
    ({"gravity": []}, "x.gravity: too few values, got []"),
    ({"gravity": [0, 0, -9.81, 0]},
     "x.gravity: tuple should have at most 3 items after validation, not 4, got [0, 0, -9.81, 0]"),
    ({"gravity": "down"}, "x.gravity: input should be a list, got 'down'"),
    ({"seed": 2**63}, "x.seed: input should be less than or equal to 9223372036854775807, got 9223372036854775808"),
    ({"time_step": 0}, "x.time_step: input should be greater than 0, got 0"),
    ({"max_wall_time": 2e6}, "x.max_wall_time: input should be less than or equal to 1000000, got 2000000.0"),
])
def test_world_scalars_are_strict_and_finite(data: dict[str, Any], expected: str) -> None:
    assert refusal(WorldConfig, data) == expected


def test_an_integer_is_a_float_and_values_are_converted() -> None:
    world = validate_model(WorldConfig, {"time_step": 0.01, "max_time": 2, "gravity": [0, 0, -10]}, "world")
    assert world.max_time == 2.0 and type(world.max_time) is float
    assert world.gravity == (0.0, 0.0, -10.0) and all(type(v) is float for v in world.gravity)
    assert validate_model(WorldConfig, {"max_wall_time": None}, "world").max_wall_time is None


def test_numbers_and_arrays_from_python_code() -> None:
    """Configs built in code (gym, sweeps, tests) may hold numpy values: accepted where pydantic's rules took them."""
    import numpy as np

    world = validate_model(WorldConfig, {"time_step": np.float32(0.0125), "max_time": np.int64(3),
                                         "gravity": np.array([0.0, 0.0, -9.81])}, "world")
    assert world.max_time == 3.0 and type(world.max_time) is float and world.gravity == (0.0, 0.0, -9.81)
    assert type(world.time_step) is float and math.isclose(world.time_step, 0.0125, rel_tol=1e-6)
    assert refusal(WorldConfig, {"seed": np.int64(3)}) == "x.seed: input should be a valid integer, got np.int64(3)"
    assert refusal(WorldConfig, {"max_time": np.bool_(True)}) == \
        "x.max_time: input should be a valid number, got np.True_"  # a bool is not a number, numpy's neither
    assert refusal(WorldConfig, {"max_time": 10**400}).startswith("x.max_time: input should be a valid number")
    assert validate_model(BodyConfig, {"shape": np.str_("box"), "position": [0, 0, 1]}, "b").shape == "box"
    assert refusal(WorldConfig, {"gravity": range(4)}) == \
        "x.gravity: tuple should have at most 3 items after validation, not 4, got range(0, 4)"


def test_unbounded_floats_are_held_within_the_float_limit() -> None:
    assert refusal(GuiConfig, {"yaw": 2e9}) == \
        "x.yaw: input should be less than or equal to 1000000000, got 2000000000.0"
    assert refusal(GuiConfig, {"yaw": -2e9}).endswith("greater than or equal to -1000000000, got -2000000000.0")
    assert refusal(RecordConfig, {"pose_hz": 1e10}).startswith("x.pose_hz: input should be less than or equal to")


def test_strings_literals_and_tables() -> None:
    body = {"shape": "box", "position": [0, 0, 1]}
    assert refusal(BodyConfig, {**body, "shape": "cube"}) == \
        "x.shape: input should be 'box', 'sphere' or 'cylinder', got 'cube'"
    assert refusal(BodyConfig, {**body, "collision": "x"}) == "x.collision: input should be 'convex' or 'mesh', got 'x'"
    assert refusal(BodyConfig, {"urdf": 5, "position": [0, 0, 1]}) == "x.urdf: input should be a valid string, got 5"
    assert refusal(BodyConfig, {"urdf": "", "position": [0, 0, 1]}) == \
        "x.urdf: string should have at least 1 character, got ''"
    assert refusal(BodyConfig, {**body, "joint_positions": [1]}) == \
        "x.joint_positions: input should be a table, got [1]"
    assert refusal(BodyConfig, {**body, "joint_positions": {"j": 2000}}) == \
        "x.joint_positions.j: input should be less than or equal to 1000, got 2000"
    assert refusal(BodyConfig, {**body, "joint_positions": {"j": True}}) == \
        "x.joint_positions.j: input should be a valid number, got True"


def test_fields_are_checked_in_declaration_order_then_unknown_keys_then_cross_field_rules() -> None:
    assert refusal(BodyConfig, {"bogus": 1, "shape": "box", "mass": -1}) == \
        "x.mass: input should be greater than or equal to 0, got -1"
    text = refusal(BodyConfig, {"colr": 1, "shape": "box", "urdf": "a.urdf"})
    assert text.startswith("x.colr: unknown key 'colr'; valid keys: angular_damping, collision, count")
    assert refusal(BodyConfig, {"shape": "box", "urdf": "a.urdf"}) == \
        "x: give exactly one of 'shape' (box, sphere, cylinder), 'urdf', 'sdf' or 'mjcf', not shape and urdf"
    assert refusal(WorldConfig, {"gravty": [0, 0, -9.81]}).startswith(
        "x.gravty: unknown key 'gravty' (did you mean 'gravity'?); valid keys: engine, gravity, gui,")


def test_nested_mount() -> None:
    mounted = {"urdf": "r2d2.urdf"}
    body = validate_model(BodyConfig, {**mounted, "mount": {"body": "a", "link": "b", "position": [0, 0, 1]}}, "x")
    assert body.mount == MountConfig(body="a", link="b", position=(0.0, 0.0, 1.0))
    assert refusal(BodyConfig, {**mounted, "mount": {"body": "a"}}) == "x.mount.link: Field required"
    assert refusal(BodyConfig, {**mounted, "mount": {"body": "a", "link": "b", "positon": [0, 0, 1]}}) == (
        "x.mount.positon: unknown key 'positon' (did you mean 'position'?); valid keys: body, link, max_force, "
        "position, rpy_deg")  # the mount's own keys, not the body's
    assert refusal(BodyConfig, {**mounted, "mount": {"body": "a", "link": "b", "position": [0, 0]}}) == \
        "x.mount.position: too few values, got [0, 0]"
    assert refusal(BodyConfig, {**mounted, "mount": 5}) == \
        "x.mount: input should be a table or instance of MountConfig, got 5"
    assert refusal(BodyConfig, {**mounted, "position": [0, 0, 1], "mount": {"body": "a", "link": "b"}}) == \
        ("x: a mounted body is placed by 'mount.position' / 'mount.rpy_deg', not 'position' / 'rpy_deg' / "
         "'quaternion'")


def test_the_colour_check_runs_before_the_components() -> None:
    body = {"shape": "box", "position": [0, 0, 1]}
    assert refusal(BodyConfig, {**body, "rgba": [255, 0, 0, 255]}) == \
        "x.rgba: colour components must be 0-1 floats, got [255, 0, 0, 255] (for 0-255 values write [1, 0, 0, 1])"
    assert refusal(BodyConfig, {**body, "rgba": [0.5, 0, 0, -1]}) == \
        "x.rgba.3: input should be greater than or equal to 0, got -1"


def test_defaults_are_the_declared_ones_and_objects_are_frozen() -> None:
    world = validate_model(WorldConfig, {}, "world")
    assert world == WorldConfig() and world.time_step == 1.0 / 240.0 and world.gravity == (0.0, 0.0, -9.81)
    a = validate_model(BodyConfig, {"shape": "box", "position": [0, 0, 1]}, "x")
    b = validate_model(BodyConfig, {"shape": "box", "position": [0, 0, 1]}, "x")
    assert a.joint_positions == {} and a.joint_positions is not b.joint_positions
    with pytest.raises(dataclasses.FrozenInstanceError):
        world.seed = 3  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.mass = 0.0  # type: ignore[misc]
    assert field_names(RecordConfig) == ("pose_hz", "save_frames")


def test_sections_survive_pickle_and_deepcopy() -> None:
    import copy
    import pickle

    body = validate_model(BodyConfig, {"urdf": "r2d2.urdf", "mount": {"body": "a", "link": "b"},
                                       "joint_positions": {"j": 0.5}}, "x")
    for twin in (pickle.loads(pickle.dumps(body)), copy.deepcopy(body)):
        assert twin == body and twin is not body and twin.mount == body.mount
        assert twin.joint_positions == {"j": 0.5} and twin.joint_positions is not body.joint_positions
    assert hash(WorldConfig()) == hash(validate_model(WorldConfig, {}, "world"))
    assert repr(MountConfig(body="a", link="b")).startswith("MountConfig(body='a', link='b', position=(0.0, 0.0, 0.0)")


def test_a_whole_config_of_core_sections(tmp_path: Any) -> None:
    cfg = build_config({"world": {"seed": 3}, "bodies": {"plane": PLANE}, "record": {"pose_hz": 10}},
                       load_plugins(), base_dir=tmp_path)
    assert isinstance(cfg, Config) and cfg.world.seed == 3 and cfg.record.pose_hz == 10.0
    assert cfg.gui == GuiConfig() and cfg.reporters[0].name == "local" and cfg.reporters[0].params.dir == "results"
    with pytest.raises(ConfigError) as exc:
        build_config({"bodies": {"plane": {**PLANE, "mass": True}}}, load_plugins(), source="scene.toml")
    assert str(exc.value) == "scene.toml: bodies.plane.mass: input should be a valid number, got True"


# ------------------------------------------------------------------ a plugin type with a light schema

class BeamConfig(Section):
    """A made-up range sensor's options."""

    body: str = setting()
    range: float = setting(2.0, gt=0, le=100, description="metres")
    mode: Literal["near", "far"] = "near"
    offsets: tuple[float, ...] = ()
    gains: dict[str, Any] = setting(default_factory=dict)

    def check(self) -> None:
        if self.mode == "far" and self.range < 10:
            raise ValueError(f"mode 'far' needs range >= 10, got {self.range}")


class Beam(Sensor):
    """A made-up range sensor (its schema is a light one)."""

    def read(self) -> float:
        return self.config.range  # type: ignore[no-any-return]


def beam_plugin() -> types.ModuleType:
    module = types.ModuleType("beam_plugin")

    @hookimpl
    def robokit_register_sensors(register: Any) -> None:
        register("beam", Beam, BeamConfig)

    module.robokit_register_sensors = robokit_register_sensors  # type: ignore[attr-defined]
    return module


def test_a_plugin_may_register_a_light_schema() -> None:
    plugins = load_plugins([beam_plugin()])
    raw = {"bodies": {"plane": PLANE}, "sensors": {"b": {"type": "beam", "body": "plane", "offsets": [1, 2]}}}
    spec = build_config(raw, plugins).sensors[0]
    assert spec.params == BeamConfig(body="plane", offsets=(1.0, 2.0))
    cases: dict[str, tuple[dict[str, Any], str]] = {
        "range = 0": ({"range": 0}, "sensors.b.range: input should be greater than 0, got 0"),
        "missing body": ({"body": None}, "sensors.b.body: input should be a valid string, got None"),
        "cross-field": ({"mode": "far"}, "sensors.b: mode 'far' needs range >= 10, got 2.0"),
        "unknown key": ({"rnage": 5}, "sensors.b.rnage: unknown key 'rnage' (did you mean 'range'?); valid keys: "
                                      "body, gains, mode, offsets, range, rate_hz, type"),
        "variadic tuple": ({"offsets": [1, "a"]}, "sensors.b.offsets.1: input should be a valid number, got 'a'"),
    }
    for name, (change, expected) in cases.items():
        section = {"type": "beam", "body": "plane", **change}
        with pytest.raises(ConfigError) as exc:
            build_config({**raw, "sensors": {"b": section}}, plugins)
        assert str(exc.value) == f"<dict>: {expected}", name


def test_bounds_inside_annotated_and_unsupported_types() -> None:
    class Grid(Section):
        cells: tuple[Annotated[int, Bounds(ge=1)], Annotated[int, Bounds(ge=1)]] = (1, 1)

    assert refusal(Grid, {"cells": [2, 0]}) == "x.cells.1: input should be greater than or equal to 1, got 0"
    assert Grid.model_validate({"cells": [3, 4]}) == Grid(cells=(3, 4))

    class Odd(Section):
        value: complex = 0j

    with pytest.raises(TypeError, match="unsupported field type"):
        validate_model(Odd, {}, "x")


def test_pydantic_schemas_keep_working_through_the_same_door() -> None:
    from pydantic import Field

    from robokit.config import Schema, validation_error  # re-exported from robokit.config.schema on first use

    class Gain(Schema):
        kp: float = Field(1.0, ge=0)

    assert validate_model(Gain, {"kp": 2}, "g").kp == 2.0
    assert refusal(Gain, {"kp": True}, "g") == "g.kp: input should be a valid number, got True"
    assert refusal(Gain, {"kpp": 1}, "g") == "g.kpp: unknown key 'kpp' (did you mean 'kp'?); valid keys: kp"
    assert callable(validation_error) and field_names(Gain) == ("kp",)


@pytest.mark.parametrize("unit", ["Coord", "Angle", "Unit", "Length", "Gravity", "Newtons"])
def test_the_pydantic_unit_types_have_the_core_sections_bounds(unit: str) -> None:
    import robokit.config
    from robokit.config import sections

    light = getattr(sections, unit).__metadata__[0]
    # (built with type(): this module postpones annotations, and a local name cannot be resolved from a string)
    Light = type("Light", (Section,), {"__annotations__": {"value": getattr(sections, unit)}, "value": 0.5})
    Rich = type("Rich", (robokit.config.Schema,), {"__annotations__": {"value": getattr(robokit.config, unit)},
                                                   "value": 0.5, "__module__": __name__})

    edges = [b for b in (light.ge, light.gt, light.le, light.lt) if b is not None]
    assert edges
    for edge in edges:
        for value in (edge, edge - 1e-3, edge + 1e-3):
            outcomes = []
            for schema in (Light, Rich):
                try:
                    outcomes.append(validate_model(schema, {"value": value}, "x").value)
                except ConfigError as exc:
                    outcomes.append(str(exc))
            assert outcomes[0] == outcomes[1], (unit, value, outcomes)
