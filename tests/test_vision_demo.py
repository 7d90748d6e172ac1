"""configs/camera_demo.toml (lesson 05): a fixed and an eye-in-hand camera both find the red and the blue cube."""

from __future__ import annotations

import math
from pathlib import Path

from robokit.testing import make_sim

CONFIG = Path(__file__).resolve().parents[1] / "configs" / "camera_demo.toml"


def test_fixed_and_wrist_cameras_locate_both_cubes() -> None:
    with make_sim(CONFIG) as sim:
        sim.step(120)  # the arm settles in its ready pose
        for detector, camera in (("fixed_eye", "fixed_cam"), ("wrist_eye", "wrist_cam")):
            seen = sim.readings[detector]
            assert [d.colour for d in seen] == ["blue", "red"], detector
            for d in seen:
                truth = sim.world.pose(f"{d.colour}_cube")[0]
                assert math.dist(d.position, truth) < 0.01, (detector, d)
            assert sim.readings.computed(camera) == 1
        red = sim.readings["wrist_eye"].of("red")[0]
        assert abs(math.degrees(red.yaw) - 20.0) < 3.0
        hand = sim.readings["wrist_cam"].eye
        assert math.dist(hand, sim.readings["fixed_cam"].eye) > 0.3  # two different viewpoints
