"""Joint reaction wrenches and applied forces on both engines, over generated loads, against statics.

The World promises (``robokit.engines.interface``): ``joint_states(...)[i].reaction`` is what the joint's child link
receives from its parent in the last step, in the child link's frame, torque about the child link's origin, once
``enable_joint_wrench`` switched measuring on (zeros otherwise, and again after it is switched off);
``wrench_frame`` is the rotation of that frame; ``apply_force`` pushes for the next step only, at a world point
(default: the link's origin). A tool held by a fixed joint does not move, so its reaction balances its weight and the
push exactly: ``F = m g_up - F_push``, ``tau = -(c - o) x m g - (p - o) x F_push`` about the link origin ``o``
(``c`` its centre of mass, ``p`` the pushed point), rotated into the link frame -- composed here from the URDF written
for the example (a generated joint orientation, base orientation, mass, centre of mass and inertial rotation, never
the identity alone) and rotation matrices built from axis and angle.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from engine_inputs import axes, tool_urdf, turns
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import quaternion_of, rodrigues, rpy_matrix

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]

NO_SHRINK = [Phase.explicit, Phase.generate]
G = 9.81


angles = st.tuples(*(st.floats(-1.4, 1.4),) * 3)
offsets = st.tuples(*(st.floats(-0.15, 0.15),) * 3)
pushes = st.tuples(*(st.floats(-6.0, 6.0),) * 3)


@settings(max_examples=10, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(joint_xyz=offsets, joint_rpy=angles, com=offsets, com_rpy=angles, mass=st.floats(0.2, 3.0), base_axis=axes,
       base_turn=turns, push=pushes, at=offsets)
def test_a_held_tool_reads_its_weight_and_each_push_for_one_step(
        world: World, tmp_path: Path, joint_xyz, joint_rpy, com, com_rpy, mass, base_axis, base_turn, push,
        at) -> None:
    text = tool_urdf(joint_xyz, joint_rpy, com, com_rpy, mass)
    path = tmp_path / f"probe-{hashlib.sha256(text.encode()).hexdigest()[:16]}.urdf"  # PyBullet keeps a path's text
    path.write_text(text, encoding="utf-8")
    base_q = quaternion_of(base_axis, base_turn)
    probe = world.load_urdf("probe", str(path), position=(0.1, -0.2, 0.6), orientation=base_q, fixed_base=True)
    try:
        wrist = world.joint(probe, "wrist").index
        spin = world.joint(probe, "spin").index
        world.enable_joint_wrench(probe, wrist)
        assert list(world.joint_states(probe, [wrist])[0][2]) == [0.0] * 6, "nothing measured before a step"
        for _ in range(3):
            world.step()
        origin, _ = world.pose(probe, wrist)
        o = np.asarray(origin)
        r_link = rodrigues(base_axis, base_turn) @ rpy_matrix(*joint_rpy)
        np.testing.assert_allclose(o, np.array([0.1, -0.2, 0.6]) + rodrigues(base_axis, base_turn) @ joint_xyz,
                                   atol=1e-6)
        assert np.asarray(world.wrench_frame(probe, wrist)).reshape(3, 3) == pytest.approx(r_link, abs=1e-6)
        centre = o + r_link @ np.asarray(com)
        weight = np.array([0.0, 0.0, -mass * G])
        tol = 2e-3 * (mass * G + float(np.linalg.norm(push))) + 1e-6

        def check(force_in: np.ndarray, point: np.ndarray, what: str) -> None:
            force = -weight - force_in
            torque = -np.cross(centre - o, weight) - np.cross(point - o, force_in)
            state = world.joint_states(probe, [spin, wrist])
            reaction = np.asarray(state[1][2])
            np.testing.assert_allclose(reaction[:3], r_link.T @ force, atol=tol, err_msg=what)
            np.testing.assert_allclose(reaction[3:], r_link.T @ torque, atol=tol * 0.4, err_msg=what)
            assert list(state[0][2]) == [0.0] * 6, "a joint not measured reads zeros"

        check(np.zeros(3), o, "hanging still")
        point = o + np.asarray(at)
        world.apply_force(probe, push, position=point.tolist(), link=wrist)
        world.step()
        check(np.asarray(push), point, "pushed at a point")
        world.step()
        check(np.zeros(3), o, "the step after the push")
        world.apply_force(probe, push, link=wrist)  # at the link's origin
        world.step()
        check(np.asarray(push), o, "pushed at the link's origin")
        world.enable_joint_wrench(probe, wrist, False)
        world.enable_joint_wrench(probe, spin, False)  # switching off a joint never measured changes nothing
        world.step()
        assert list(world.joint_states(probe, [wrist])[0][2]) == [0.0] * 6, "measuring switched off"
    finally:
        world.remove_body("probe")
