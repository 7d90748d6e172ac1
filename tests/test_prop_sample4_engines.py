"""Engine frame arithmetic judged by the world: ``attach`` keeps a body where it is relative to its parent however
both are turned (the body does not move when the constraint takes hold), and a MuJoCo ``restore`` puts the state of
its snapshot back so that what follows is what followed the snapshot the first time (no motor ramp carried over)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.testing import PLANE, make_sim


@pytest.fixture(scope="module")
def turned_bodies():
    config = {"bodies": {
        "cup": {"shape": "box", "size": [0.1, 0.06, 0.04], "mass": 0, "position": [0.3, -0.2, 0.8],
                "rpy_deg": [25, -40, 70]},
        "load": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.2, "position": [0.42, -0.05, 0.7],
                 "rpy_deg": [-10, 15, 200]},
    }}
    with make_sim(config) as sim:
        yield sim


def test_attach_keeps_the_child_where_it_is_relative_to_a_turned_parent(turned_bodies):
    sim, w = turned_bodies, turned_bodies.world
    before = w.pose("load")
    cid = w.attach(w.body("cup"), -1, w.body("load"))
    try:
        sim.step(60)
        after = w.pose("load")
    finally:
        w.detach(cid)
    assert math.dist(before[0], after[0]) < 5e-3
    assert abs(float(np.dot(before[1], after[1]))) > 0.999  # same orientation (q and -q alike)


@pytest.fixture(scope="module")
def mujoco_robot():
    config = {"world": {"engine": "mujoco"}, "bodies": {"plane": PLANE},
              "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}}}
    with make_sim(config) as sim:
        yield sim.world


def test_a_mujoco_restore_leaves_no_motor_ramp_running(mujoco_robot):
    w = mujoco_robot
    body = w.body("robot")
    joint = w.joint(body, "left_wheel").index
    snap = w.snapshot()
    for _ in range(40):
        w.step()
    untouched = w.joint_states(body, [joint])[0][0]  # what follows the snapshot with no command
    w.restore(snap)
    w.set_joint_motor(body, joint, "position", target_position=3.0, max_velocity=2.0, force=5.0)
    for _ in range(3):  # a capped move under way...
        w.step()
    w.restore(snap)  # ...and the episode starts over
    for _ in range(40):
        w.step()
    again = w.joint_states(body, [joint])[0][0]
    assert again == pytest.approx(untouched, abs=1e-6)
