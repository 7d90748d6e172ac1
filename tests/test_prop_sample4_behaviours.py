"""pick_place's goal judged against the world: an object at the place spot that still touches the robot has not been
placed (the promise: it rests, not touching the robot), and one that rests there free of the robot has."""

from __future__ import annotations

import pytest
from robokit_behaviours.pick_place_jobs import object_rests_at

from robokit.testing import PLANE, make_sim


@pytest.fixture(scope="module")
def world_with_a_held_cube():
    config = {"bodies": {
        "plane": PLANE,
        "robot": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0, "position": [0, 0, 0.05]},
        "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0, 0, 0.126]},
        "free": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0.5, 0, 0.026]},
    }}
    with make_sim(config) as sim:
        sim.step(120)
        yield sim.world


@pytest.mark.parametrize("name", ["cube", "free"])
def test_the_goal_is_met_only_by_an_object_resting_free_of_the_robot(world_with_a_held_cube, name):
    world = world_with_a_held_cube
    spot = world.pose(name)[0]
    touching = bool(world.contacts(world.body(name), world.body("robot")))  # the world's own answer
    assert touching == (name == "cube")
    check = object_rests_at(world, name, spot, 0.01, "robot")
    assert check.met is (not touching), check.reason
