"""Config promises at their boundaries: ge/le bounds include the bound, whole numbers and numbers refuse true/false,
rates must divide the physics rate (and not exceed it), 0-255 colours get their 0-1 equivalent, "did you mean"
only for a close name."""

from __future__ import annotations

import pytest

from robokit.errors import ConfigError, did_you_mean
from robokit.testing import PLANE, make_sim


def scene(**sections: object) -> dict:
    return {"bodies": {"plane": PLANE,
                       "cube": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.05]}},
            **sections}


def error(cfg: dict) -> str:
    with pytest.raises(ConfigError) as info:
        make_sim(cfg)
    return str(info.value)


def test_bounds_include_the_bound_itself() -> None:
    """world.seed: ge 0, le 2**63 - 1; events.at: ge 0; regions' min_spacing ge 0: the bounds themselves are valid."""
    for seed in (0, 2**63 - 1):
        with make_sim(scene(world={"seed": seed, "max_time": 1e6})) as sim:
            assert sim.world.seed == seed
    with make_sim(scene(events=[{"at": 0.0, "type": "remove", "body": "cube", "duration": 0.0}])):
        pass
    assert "greater than or equal to 0" in error(scene(world={"seed": -1}))
    assert "less than or equal to 1000000" in error(scene(world={"max_time": 1e6 + 1}))


@pytest.mark.parametrize(("key", "value"), [("seed", True), ("solver_iterations", False), ("max_time", True)])
def test_true_and_false_are_not_numbers(key: str, value: bool) -> None:
    message = error(scene(world={key: value}))
    assert f"world.{key}" in message and ("integer" in message or "number" in message)


@pytest.mark.parametrize("hz", [100, 110, 75, 480, 250, 1e9])
def test_a_rate_must_divide_the_physics_rate(hz: int) -> None:
    cfg = scene(sensors={"pose": {"type": "body_pose", "bodies": ["cube"], "rate_hz": hz}})
    assert "does not divide the physics rate 240 Hz" in error(cfg)


@pytest.mark.parametrize("hz", [240, 120, 80, 60, 48, 1])
def test_rates_that_divide_it_are_accepted(hz: int) -> None:
    with make_sim(scene(sensors={"pose": {"type": "body_pose", "bodies": ["cube"], "rate_hz": hz}})):
        pass


def test_a_0_255_colour_gets_its_0_1_equivalent() -> None:
    cfg = scene()
    cfg["bodies"]["cube"]["rgba"] = [255, 0, 51, 255]
    message = error(cfg)
    assert "colour components must be 0-1 floats" in message
    assert "for 0-255 values write [1, 0, 0.2, 1]" in message


def test_did_you_mean_only_for_a_close_name() -> None:
    assert did_you_mean("sensor", ["sensors", "bodies"]) == " (did you mean 'sensors'?)"
    assert did_you_mean("zzqqxx", ["sensors", "bodies"]) == ""
    message = error({**scene(), "sensorz": {}})
    assert "did you mean 'sensors'" in message
    assert "did you mean" not in error({**scene(), "qqqqqqq": {}})
