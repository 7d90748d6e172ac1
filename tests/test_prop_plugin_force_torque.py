"""The force-torque sensor against statics, on generated tools at random orientations, on both engines.

The plugin promises (plugins/force_torque.py, robokit.msgs.sensing.Wrench): the wrench the joint's child link
receives from its parent, in the child link's frame, torque about the child link's origin; with ``world_frame`` the
same vectors in the world frame. A tool hanging still from a fixed joint is held up by exactly its weight, so the
reading must be ``F = m g`` upwards and ``tau = (c - o) x F`` (``c`` its centre of mass, ``o`` its link origin),
rotated into the link frame by the link's orientation -- all computed here from the URDF written for the example
and the world's link pose, with a rotation matrix built from the quaternion by axis and angle. Each example's tool
has a generated joint orientation, centre-of-mass offset and inertial-frame rotation (never the identity alone):
a sensor that reports about the centre of mass, or in the inertial frame, fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from engine_inputs import tool_urdf
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import rotation, rpy_matrix

from robokit.errors import ConfigError
from robokit.testing import make_sim

NO_SHRINK = [Phase.explicit, Phase.generate]  # an example is a simulation: a failing one is reported as drawn

ENGINES = ["pybullet", "mujoco"]
G = 9.81
WRIST = (0.05, -0.02, 0.3)  # the tool's joint in the base frame


angles = st.tuples(*(st.floats(-1.4, 1.4),) * 3)


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=4, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(joint_rpy=angles, base_rpy=angles, inertial_rpy=angles, mass=st.floats(0.2, 3.0),
       com=st.tuples(*(st.floats(-0.15, 0.15),) * 3))
def test_a_hanging_tool_reads_its_weight_and_moment_about_the_link_origin(
        engine: str, tmp_path: Path, joint_rpy: tuple, base_rpy: tuple, inertial_rpy: tuple, mass: float,
        com: tuple) -> None:
    urdf = tmp_path / "probe.urdf"
    urdf.write_text(tool_urdf(WRIST, joint_rpy, com, inertial_rpy, mass, base_collision=True), encoding="utf-8")
    config = {
        "world": {"engine": engine, "gravity": [0, 0, -G]},
        "robots": {"probe": {"urdf": str(urdf), "position": [0, 0, 0.5], "fixed_base": True,
                             "rpy_deg": [float(v) for v in np.degrees(base_rpy)]}},
        "sensors": {"ft": {"type": "force_torque", "body": "probe", "joint": "wrist"},
                    "ftw": {"type": "force_torque", "body": "probe", "joint": "wrist", "world_frame": True}},
    }
    with make_sim(config) as sim:
        sim.step(5)
        w = sim.world
        tool = w.joint("probe", "wrist").index
        origin, orn = w.pose("probe", tool)
        r_link = rotation(orn)
        centre = np.array(origin) + r_link @ np.array(com)  # the URDF's inertial origin, in the world
        force = np.array([0.0, 0.0, mass * G])  # the parent holds the tool up against its weight
        torque = np.cross(centre - np.array(origin), force)
        local, world = sim.readings["ft"], sim.readings["ftw"]
        assert local.frame == "tool" and world.frame == "world"
        np.testing.assert_allclose(world.force, force, atol=2e-3 * mass * G + 1e-6)
        np.testing.assert_allclose(world.torque, torque, atol=2e-3 * mass * G * 0.3 + 1e-6)
        np.testing.assert_allclose(local.force, r_link.T @ force, atol=2e-3 * mass * G + 1e-6)
        np.testing.assert_allclose(local.torque, r_link.T @ torque, atol=2e-3 * mass * G * 0.3 + 1e-6)
        # the link frame is the URDF's: base orientation times the joint's rpy (not the inertial frame's)
        np.testing.assert_allclose(r_link, rpy_matrix(*base_rpy) @ rpy_matrix(*joint_rpy), atol=1e-6)


def probe_config(tmp_path: Path, sensors: dict) -> dict:
    urdf = tmp_path / "probe.urdf"
    urdf.write_text(tool_urdf(WRIST, (0.3, -0.2, 0.5), (0.05, 0.0, -0.04), (0.0, 0.0, 0.0), 1.5,
                              base_collision=True), encoding="utf-8")
    return {"world": {"gravity": [0, 0, -G]},
            "robots": {"probe": {"urdf": str(urdf), "position": [0, 0, 0.5], "fixed_base": True}},
            "sensors": sensors}


def test_noise_is_zero_mean_with_its_standard_deviation_on_all_six_axes_and_readings_carry_the_sim_time(
        tmp_path: Path) -> None:
    """A noisy and a clean sensor on one joint: their differences over 150 ticks have mean 0 and the configured
    standard deviation on each of the six axes, drawn independently (bounds from the sample sizes); every reading
    is stamped with the world's time."""
    std = 0.5
    sensors = {"clean": {"type": "force_torque", "body": "probe", "joint": "wrist"},
               "noisy": {"type": "force_torque", "body": "probe", "joint": "wrist", "noise_std": std}}
    with make_sim(probe_config(tmp_path, sensors)) as sim:
        diffs = []
        for _ in range(150):
            sim.step(1)
            clean, noisy = sim.readings["clean"], sim.readings["noisy"]
            assert clean.time == noisy.time == pytest.approx(sim.world.time)
            diffs.append(np.subtract([*noisy.force, *noisy.torque], [*clean.force, *clean.torque]))
    d = np.array(diffs)
    assert d.shape == (150, 6)
    np.testing.assert_allclose(d.mean(axis=0), 0.0, atol=5 * std / np.sqrt(150))
    np.testing.assert_allclose(d.std(axis=0), std, rtol=0.2)
    corr = np.corrcoef(d.T)  # six draws a tick, not one shared by every axis
    assert np.abs(corr[~np.eye(6, dtype=bool)]).max() < 0.35


def test_a_closed_sensor_switches_the_joints_measurement_off_and_an_unknown_joint_is_refused_at_its_key(
        tmp_path: Path) -> None:
    """While the sensor is open the world measures the joint's reaction (the tool's weight); once it is closed
    the world reports none (PyBullet's reaction of a joint without a sensor is zero)."""
    sensors = {"ft": {"type": "force_torque", "body": "probe", "joint": "wrist"}}
    with make_sim(probe_config(tmp_path, sensors)) as sim:
        sim.step(3)
        world = sim.world
        body, joint = world.body("probe"), world.joint("probe", "wrist").index
        assert np.linalg.norm(world.joint_states(body, [joint])[0][2][:3]) == pytest.approx(1.5 * G, rel=0.01)
        sim.components["ft"].close()
        world.step()
        assert np.allclose(world.joint_states(body, [joint])[0][2], 0.0)
    with pytest.raises(ConfigError, match="elbow") as err:
        make_sim(probe_config(tmp_path, {"ft": {"type": "force_torque", "body": "probe", "joint": "elbow"}}))
    assert err.value.key == "sensors.ft.joint"
