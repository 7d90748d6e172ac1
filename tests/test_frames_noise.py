"""World poses in the link (URDF) frame and the centre-of-mass frame; sensor noise per tick, not per read."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.testing import check_sensor, make_sim

DIFFBOT = {"urdf": "robots/diffbot.urdf", "position": [0.5, -0.2, 0.06], "rpy_deg": [0, 0, 90]}
SCENE = {"bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                    "wall": {"shape": "box", "size": [0.1, 2, 0.5], "mass": 0, "position": [1.5, 0, 0.25]}},
         "robots": {"robot": DIFFBOT}}


def test_pose_is_the_link_frame_and_com_pose_the_centre_of_mass() -> None:
    with make_sim(SCENE) as sim:
        w = sim.world
        (x, y, z), orn = w.pose("robot")
        (cx, cy, cz), corn = w.com_pose("robot")
        # the config's position is the link frame; the diffbot's inertial origin is 2 cm behind it (-x, body frame)
        assert (x, y, z) == pytest.approx((0.5, -0.2, 0.06), abs=1e-6)
        assert (cx, cy, cz) == pytest.approx((0.5, -0.22, 0.06), abs=1e-6)  # facing +y: 2 cm behind is -y
        assert np.allclose(orn, corn)
        offset = w.link_offset("robot")
        assert offset is not None and np.allclose(offset[0], (0.02, 0.0, 0.0)) and np.allclose(offset[1], (0, 0, 0, 1))
        assert w.link_offset("wall") is None and w.pose("wall") == w.com_pose("wall")
        sim.step(120)
        pos, orn = w.pose("robot")
        composed = w.client.multiplyTransforms(*w.com_pose("robot"), *w.link_offset("robot"))
        assert np.allclose(pos, composed[0]) and np.allclose(orn, composed[1])
        w.set_pose("robot", (0.0, 0.0, 0.06), orn)  # set_pose takes the link frame too
        assert w.pose("robot")[0] == pytest.approx((0.0, 0.0, 0.06), abs=1e-6)


def test_a_lidar_mounted_on_the_base_link_with_an_offset_sits_where_the_urdf_says() -> None:
    base = "base_link"
    raw = {**SCENE, "sensors": {
        "on_base": {"type": "lidar", "link": base, "offset": [0.06, 0.0, 0.06], "rays": 8},
        "on_mount": {"type": "lidar", "link": "lidar_link", "rays": 8}}}
    with make_sim(raw) as sim:
        sim.step(1)
        on_base, on_mount = sim.readings["on_base"], sim.readings["on_mount"]
    # lidar_link's joint is at (0.06, 0, 0.06) in base_link: the same place (it was 2 cm off in the COM frame)
    assert np.allclose(on_base.origin, on_mount.origin, atol=1e-6)
    assert np.allclose(on_base.ranges, on_mount.ranges, atol=1e-6)


def test_diff_drive_reports_the_link_frame_pose() -> None:
    raw = {**SCENE, "actuators": {"drive": {"type": "diff_drive"}}}
    with make_sim(raw) as sim:
        sim.step(1)
        x, y, yaw = sim.readings["drive"].pose
        assert (x, y) == pytest.approx((0.5, -0.2), abs=1e-3) and yaw == pytest.approx(math.pi / 2, abs=1e-3)


NOISY = {**SCENE, "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
         "sensors": {"scan": {"type": "lidar", "rays": 90, "range_max": 3.0, "range_noise": 0.01, "rate_hz": 60}}}


def scans(peek: bool) -> list[np.ndarray]:
    out = []
    with make_sim(NOISY, seed=4) as sim:
        slot = sim.scheduler.slots["scan"]
        for _ in range(24):
            sim.step(1)
            if peek and slot.stale:
                slot.component.read()  # someone else looks: computed out of band
                slot.component.read()
            out.append(sim.readings["scan"].ranges.copy())
    return out


def test_extra_reads_never_change_the_noise_a_run_sees() -> None:
    plain, peeked = scans(False), scans(True)
    assert all(np.array_equal(a, b) for a, b in zip(plain, peeked, strict=True))
    assert not np.array_equal(plain[0], plain[4])  # noise differs from tick to tick (every 4th tick is due)
    assert not np.array_equal(plain[4], plain[8])


def test_the_lidar_with_noise_passes_the_extra_reads_check() -> None:
    report = check_sensor("lidar", {"robot": "robot", "rays": 36, "range_max": 3.0, "range_noise": 0.01},
                          scene={k: v for k, v in NOISY.items() if k != "sensors"})
    assert any("extra read() calls do not change later readings" in line for line in report.checks)
