"""Tests of the ``imu`` sensor with robokit's own testing helpers (DIRECT mode, fixed seeds, tick-stepped).

Run them after installing the package: ``pip install -e examples/robokit-example-plugin`` then
``pytest examples/robokit-example-plugin/tests``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robokit.cli import main
from robokit.testing import PLANE, check_sensor, make_sim

from robokit_example_imu import ImuReading

G = 9.81
CONFIG = Path(__file__).resolve().parents[1] / "configs" / "imu_demo.toml"


def scene(imu: dict, *, gravity: tuple[float, float, float] = (0.0, 0.0, -G), **bodies: dict) -> dict:
    """A config dict: a ground plane, the given bodies, and one ``imu`` sensor."""
    return {
        "world": {"gravity": list(gravity)},
        "bodies": {"plane": PLANE, **bodies},
        "sensors": {"imu": {"type": "imu", **imu}},
    }


def link_rotation(sim, body: str, link: int = -1) -> np.ndarray:
    """Rotation matrix of a link frame (columns = link axes, world frame)."""
    _, orn = sim.world.pose(body, link)
    return np.asarray(sim.world.client.getMatrixFromQuaternion(orn)).reshape(3, 3)


def test_conforms_to_the_sensor_contract():
    report = check_sensor("imu")
    assert report.origin.startswith("robokit-example-imu")
    assert report.computed == 12  # 48 ticks at a quarter of the physics rate: every due tick, read or not


def test_at_rest_reads_plus_g_along_the_up_axis_and_no_rotation():
    box = {"shape": "box", "size": [0.2, 0.2, 0.1], "position": [0, 0, 0.05]}
    with make_sim(scene({"body": "box"}, box=box)) as sim:
        samples = []
        for _ in range(240):
            sim.step(1)
            samples.append(sim.readings["imu"])
    acc = np.array([s.linear_acceleration for s in samples[120:]]).mean(axis=0)
    gyro = np.array([s.angular_velocity for s in samples[120:]]).mean(axis=0)
    assert acc == pytest.approx([0.0, 0.0, G], abs=0.05)
    assert gyro == pytest.approx([0.0, 0.0, 0.0], abs=1e-3)
    assert isinstance(samples[-1], ImuReading)


def test_free_fall_reads_no_specific_force():
    # no air drag (PyBullet's default linear damping acts like one, and an accelerometer would feel it)
    ball = {"shape": "sphere", "radius": 0.05, "position": [0, 0, 5.0], "linear_damping": 0.0}
    with make_sim(scene({"body": "ball"}, ball=ball)) as sim:
        sim.step(48)  # 0.2 s: still falling, far above the ground
        acc = np.array(sim.readings["imu"].linear_acceleration)
        assert sim.world.velocity("ball")[0][2] < -1.5
    assert np.linalg.norm(acc) < 1e-3


def test_measures_in_the_link_frame_of_a_box_on_its_side():
    # rotated +90 deg about x: the box's +y axis points up, so gravity's reaction reads along +y
    box = {"shape": "box", "size": [0.2, 0.1, 0.2], "position": [0, 0, 0.05], "rpy_deg": [90, 0, 0]}
    with make_sim(scene({"body": "box"}, box=box)) as sim:
        sim.step(120)
        acc = np.array(sim.readings["imu"].linear_acceleration)
    assert acc == pytest.approx([0.0, G, 0.0], abs=0.05)


def test_gyro_reads_spin_in_the_link_frame():
    # no gravity; the box spins at 2 rad/s about world z while its own +y axis points along world z
    box = {"shape": "box", "size": [0.2, 0.1, 0.3], "position": [0, 0, 1.0], "rpy_deg": [90, 0, 0]}
    with make_sim(scene({"body": "box"}, gravity=(0.0, 0.0, 0.0), box=box)) as sim:
        sim.world.client.resetBaseVelocity(sim.world.body("box"), [0, 0, 0], [0, 0, 2.0])
        sim.step(23)
        expected = link_rotation(sim, "box").T @ np.array(sim.world.velocity("box")[1])
        sim.step(1)  # the IMU samples at the start of the tick, before the physics step
        reading = sim.readings["imu"]
    assert reading.angular_velocity == pytest.approx(tuple(expected), abs=1e-9)
    assert reading.angular_velocity == pytest.approx((0.0, 2.0, 0.0), abs=0.05)
    assert np.linalg.norm(reading.linear_acceleration) < 0.05  # the centre of mass is not accelerating


def test_imu_on_a_named_urdf_link():
    kuka = {"urdf": "kuka_iiwa/model.urdf", "position": [0, 0, 0], "fixed_base": True,
            "joint_positions": {"lbr_iiwa_joint_2": 0.8, "lbr_iiwa_joint_4": -1.0}}
    config = scene({"body": "arm", "link": "lbr_iiwa_link_7"})
    config["robots"] = {"arm": kuka}
    with make_sim(config) as sim:
        sim.step(2)
        link = sim.world.link("arm", "lbr_iiwa_link_7")
        acc = np.array(sim.readings["imu"].linear_acceleration)
        expected = link_rotation(sim, "arm", link).T @ np.array([0.0, 0.0, G])
    assert acc == pytest.approx(expected, abs=0.2)  # the arm sags a little under its default motors
    assert abs(np.linalg.norm(acc) - G) < 0.2
    assert abs(acc[2] - G) > 1.0  # the link is tilted: this is not the world frame


def noisy_samples(seed: int, n: int = 200) -> np.ndarray:
    box = {"shape": "box", "size": [0.2, 0.2, 0.1], "position": [0, 0, 0.05]}
    imu = {"body": "box", "accel_noise_std": 0.2, "gyro_noise_std": 0.02}
    with make_sim(scene(imu, box=box), seed=seed) as sim:
        sim.step(60)
        out = []
        for _ in range(n):
            sim.step(1)
            r = sim.readings["imu"]
            out.append([*r.linear_acceleration, *r.angular_velocity])
    return np.array(out)


def test_noise_has_the_configured_spread_and_comes_from_the_run_seed():
    a, b, c = noisy_samples(1), noisy_samples(1), noisy_samples(2)
    assert np.array_equal(a, b)  # same seed, same noise
    assert not np.array_equal(a, c)
    assert a[:, :3].std(axis=0) == pytest.approx([0.2, 0.2, 0.2], rel=0.2)
    assert a[:, 3:].std(axis=0) == pytest.approx([0.02, 0.02, 0.02], rel=0.2)


def test_unknown_link_is_one_line_config_error(tmp_path, capsys):
    cfg = tmp_path / "bad.toml"
    text = CONFIG.read_text().replace('body = "box"                 #', 'link = "lid"\nbody = "box" #')
    cfg.write_text(text)
    assert main(["validate", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert "sensors.imu.link: unknown link 'lid'" in err and "valid:" in err


def test_demo_config_records_imu_samples_in_the_trace(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the local reporter writes results/ here
    trace = tmp_path / "trace.jsonl"
    assert main(["run", str(CONFIG), "--trace", str(trace), "--quiet"]) == 0
    import json

    records = [json.loads(line) for line in trace.read_text().splitlines()]
    samples = [r["value"] for r in records if r["kind"] == "reading" and r["component"] == "imu"]
    assert len(samples) == 121  # 2 s at 60 Hz, both ends included
    settled = np.array([s["linear_acceleration"] for s in samples[-20:]]).mean(axis=0)
    assert np.linalg.norm(settled) == pytest.approx(G, abs=0.1)
