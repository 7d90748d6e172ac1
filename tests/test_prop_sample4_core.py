"""Sensor dropout across episodes, judged by the world: after the randomizer starts a new episode
(``apply_world``), the first reading of a dropping sensor is the world as it is now, never a reading held over from
the episode before."""

from __future__ import annotations

import pytest

from robokit.testing import PLANE, make_sim


@pytest.fixture
def dropping_sim():
    config = {
        "bodies": {"plane": PLANE,
                   "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.05]}},
        "sensors": {"pose": {"type": "body_pose", "bodies": ["box"]}},
        "randomize": {"dropout": {"pose": [1.0, 1.0]}},  # every tick drops: the held reading is returned
    }
    with make_sim(config, seed=3) as sim:
        yield sim


@pytest.mark.parametrize("x", [0.4, -0.7])
def test_a_new_episode_starts_with_a_fresh_reading(dropping_sim, x):
    sim, world = dropping_sim, dropping_sim.world
    sensor = sim.components["pose"]
    first = sensor.read()["box"].position
    world.set_pose("box", [x, 0.3, 0.05])
    sim.step(2)
    assert sensor.read()["box"].position == first  # dropout at work within the episode
    sim.randomizer.apply_world(world)  # a new episode
    now = world.pose("box")[0]
    fresh = sensor.read()["box"].position
    assert fresh == pytest.approx(now, abs=1e-9)
    assert fresh[0] == pytest.approx(x, abs=0.01)
