"""The plugin contract, checked over every registered sensor and actuator type, and the checker itself.

``test_builtin_type_conforms`` is parametrised over every sensor and actuator robokit ships (and any installed
third-party type that declares an ``example``). A built-in type that declares no ``example`` fails here on purpose:
see docs/plugins.md, "Conformance".
"""

from __future__ import annotations

import types
from typing import Any

import numpy as np
import pytest

from robokit import hookimpl
from robokit.components import Actuator, Sensor
from robokit.config import Schema
from robokit.plugin_api.plugins import load_plugins
from robokit.testing import ConformanceError, check_actuator, check_sensor, first_difference

CHECKS = {"sensor": check_sensor, "actuator": check_actuator}


def registered_types() -> list[Any]:
    plugins = load_plugins()
    params = []
    for kind in CHECKS:
        for name, ptype in sorted(plugins.types[kind].items()):
            if ptype.distribution == "robokit" or getattr(ptype.cls, "example", None) is not None:
                params.append(pytest.param(kind, name, id=f"{kind}:{name}"))
    return params


@pytest.mark.parametrize(("kind", "type_name"), registered_types())
def test_builtin_type_conforms(kind: str, type_name: str) -> None:
    report = CHECKS[kind](type_name)
    assert report.type_name == type_name and len(report.checks) >= 7
    assert report.computed >= 1


# ----------------------------------------------------------------------------- the checker catches faults
SCENE = {
    "bodies": {
        "plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
        "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "position": [0, 0, 0.05]},
    }
}


class HeightConfig(Schema):
    """``body``: whose height to read."""

    body: str = "box"


class Height(Sensor):
    """Height of a body's base, metres (a well-behaved sensor)."""

    reading_type = float
    example = {"config": {}, **SCENE}

    def read(self) -> float:
        return float(self.world.pose(self.config.body)[0][2])


def plugin(kind: str, type_name: str, cls: type, schema: type | None = HeightConfig) -> types.ModuleType:
    """A plugin object (a module) registering one type, for ``extra_plugins``."""
    module = types.ModuleType(f"conformance_probe_{type_name}")

    @hookimpl
    def register_types(register: Any) -> None:
        register(type_name, cls, schema)

    setattr(module, f"robokit_register_{kind}s", register_types)
    return module


def test_a_good_sensor_passes_and_the_report_says_what_was_checked() -> None:
    report = check_sensor("height", extra_plugins=[plugin("sensor", "height", Height)])
    assert report.origin == "<local>" and report.period == 4 and report.computed == 12
    text = str(report)
    for phrase in ("declares schema HeightConfig", "rejects unknown config keys", "computed only when due",
                   "every reading is a float", "deterministic", "computed only when read (lazy)",
                   "close() releases"):
        assert phrase in text


def test_config_and_scene_can_be_given_instead_of_an_example() -> None:
    class Bare(Height):
        """Height without an example."""

        example = None

    with pytest.raises(ConformanceError, match=r"sensor type 'bare' \(<local>\): example: Bare declares no `example`"):
        check_sensor("bare", extra_plugins=[plugin("sensor", "bare", Bare)])
    report = check_sensor("bare", {"body": "box"}, scene=SCENE, ticks=16, rate_hz=120,
                          extra_plugins=[plugin("sensor", "bare", Bare)])
    assert (report.period, report.ticks, report.computed) == (2, 16, 8)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("no_schema", r"schema: registered config schema None"),
        ("open_schema", r"schema: an unknown key 'zz_conformance_unknown_key' was accepted"),
        ("no_reading_type", r"reading_type: Undeclared.reading_type is <class 'object'>"),
        ("wrong_reading", r"shape: reading after tick 0 is a int, declared reading_type is float"),
        ("unseeded", r"determinism: same seed 0, reading after tick 0 differs between two fresh simulations"),
        ("noise_per_read", r"extra reads: reading after tick 0 changed at reading .* because read\(\) was called once "
                           r"more before it: draw per-reading noise from ctx.tick_rng\(\), not ctx.rng"),
        ("leaky", r"close: 1 constraints in the world after close\(\), 0 in the same scene without the sensor"),
        ("fragile_close", r"close: a second close\(\) raised RuntimeError: already closed"),
        ("crashing", r"run: raised at tick 5: PluginError: sensor 'crashing' .* ZeroDivisionError"),
    ],
)
def test_the_checker_catches_a_broken_sensor(case: str, message: str) -> None:
    cls, schema = BROKEN_SENSORS[case]
    with pytest.raises(ConformanceError, match=message):
        check_sensor(case, extra_plugins=[plugin("sensor", case, cls, schema)])


class OpenConfig(HeightConfig):
    """A pydantic model that lets unknown keys through."""

    model_config = {"extra": "allow", "frozen": True}


class Undeclared(Height):
    """Declares no reading_type."""

    reading_type = object


class WrongReading(Height):
    """Returns ints while declaring floats."""

    def read(self) -> Any:
        return 1


class Unseeded(Height):
    """Draws noise from an unseeded generator instead of ctx.rng."""

    def read(self) -> float:
        return super().read() + float(np.random.default_rng().normal())


class NoisePerRead(Height):
    """Draws noise from ctx.rng at every read: seeded, but a second read changes the next reading."""

    def read(self) -> float:
        return super().read() + float(self.ctx.rng.normal(0.0, 0.01))


class Leaky(Height):
    """Welds the box to the world and never removes the constraint."""

    def setup(self, ctx: Any) -> None:
        super().setup(ctx)
        c = self.world.client
        c.createConstraint(self.world.body("box"), -1, -1, -1, c.JOINT_FIXED, [0, 0, 0], [0, 0, 0], [0, 0, 0.05])


class FragileClose(Height):
    """Raises when closed twice."""

    def close(self) -> None:
        if getattr(self, "closed", False):
            raise RuntimeError("already closed")
        self.closed = True


class Crashing(Height):
    """Divides by zero on its second reading."""

    def read(self) -> float:
        self.n = getattr(self, "n", 0) + 1
        return 1.0 / (2 - self.n) if self.n >= 2 else 0.0


BROKEN_SENSORS: dict[str, tuple[type, type | None]] = {
    "no_schema": (Height, None),
    "open_schema": (Height, OpenConfig),
    "no_reading_type": (Undeclared, HeightConfig),
    "wrong_reading": (WrongReading, HeightConfig),
    "unseeded": (Unseeded, HeightConfig),
    "noise_per_read": (NoisePerRead, HeightConfig),
    "leaky": (Leaky, HeightConfig),
    "fragile_close": (FragileClose, HeightConfig),
    "crashing": (Crashing, HeightConfig),
}


class PushConfig(Schema):
    """``force``: newtons along +x applied to the box while commanded."""

    force: float = 1.0


class Push(Actuator):
    """Pushes the box along +x while its command is True."""

    reading_type = bool
    example = {"config": {"force": 2.0}, **SCENE, "commands": [(0, True), (20, False)]}

    def setup(self, ctx: Any) -> None:
        super().setup(ctx)
        self.on = False

    def command(self, cmd: Any) -> None:
        if not isinstance(cmd, bool):
            raise ValueError(f"push expects True or False, got {cmd!r}")
        self.on = cmd

    def update(self) -> None:
        if self.on:
            self.world.apply_force("box", (self.config.force, 0.0, 0.0))

    def read(self) -> bool:
        return self.on


class Gullible(Push):
    """Accepts any command."""

    def command(self, cmd: Any) -> None:
        self.on = bool(cmd)


def test_a_good_actuator_passes() -> None:
    report = check_actuator("push", extra_plugins=[plugin("actuator", "push", Push, PushConfig)])
    assert report.computed == 12 and "update() runs exactly on its due ticks" in str(report)


def test_the_checker_catches_an_actuator_accepting_any_command() -> None:
    with pytest.raises(ConformanceError, match=r"command: command\(object\(\)\) was accepted"):
        check_actuator("gullible", extra_plugins=[plugin("actuator", "gullible", Gullible, PushConfig)])


def test_unknown_type_is_a_clear_failure() -> None:
    with pytest.raises(ConformanceError, match=r"sensor type 'no_such_type': not registered: unknown sensor type"):
        check_sensor("no_such_type")


def test_first_difference_points_at_the_field() -> None:
    a = {"scan": np.array([1.0, np.nan, 3.0]), "pose": (0.0, 1.0)}
    assert first_difference(a, {"scan": np.array([1.0, np.nan, 3.0]), "pose": (0.0, 1.0)}) is None
    assert first_difference(a, {"scan": np.array([1.0, np.nan, 3.5]), "pose": (0.0, 1.0)}) == \
        "reading['scan'] (arrays differ)"
    assert first_difference(a, {"scan": a["scan"], "pose": (0.0, 2.0)}) == "reading['pose'][1] (1.0 vs 2.0)"
