"""The ``camera`` sensor: image formats, metric depth, segmentation by name, eye-in-hand mounting, laziness."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from robokit.msgs.vision import CameraFrame
from robokit.testing import PLANE

CUBE = {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0.0, "position": [0.0, 0.0, 0.05], "rgba": [1, 0, 0, 1]}


def scene(camera: dict[str, Any], **bodies: Any) -> dict[str, Any]:
    """A plane, a static 10 cm red cube at the origin, extra bodies and one camera named ``cam``."""
    return {"bodies": {"plane": PLANE, "cube": CUBE, **bodies},
            "sensors": {"cam": {"type": "camera", "width": 80, "height": 60, **camera}}}


OVERHEAD = {"eye": [0.0, 0.0, 1.0], "target": [0.0, 0.0, 0.0], "up": [1.0, 0.0, 0.0], "near": 0.1, "far": 3.0}


def test_frame_formats_depth_in_metres_and_segmentation_by_name(sim_factory: Any) -> None:
    sim = sim_factory(scene(OVERHEAD))
    frame = sim.readings["cam"]
    assert isinstance(frame, CameraFrame)
    assert frame.rgb.shape == (60, 80, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (60, 80) and frame.depth.dtype == np.float32
    # centre pixel sees the cube's top face (z = 0.1) from 1 m: 0.9 m; a corner sees the plane: ~1 m / cos
    assert frame.depth[30, 40] == pytest.approx(0.9, abs=0.003)
    assert frame.body_at(40, 30) == "cube"
    assert frame.body_at(0, 0) == "plane"
    assert frame.depth[0, 0] > 1.0
    assert frame.rgb[30, 40, 0] > 150 and frame.rgb[30, 40, 2] < 60
    assert frame.body_mask("cube").sum() > 20


def test_deprojected_depth_lands_on_the_surfaces(sim_factory: Any) -> None:
    sim = sim_factory(scene(OVERHEAD))
    frame = sim.readings["cam"]
    top = frame.points(frame.body_mask("cube"))
    assert np.allclose(top[:, 2], 0.1, atol=0.002)
    assert np.abs(top[:, :2]).max() <= 0.05 + 0.005
    floor = frame.points(frame.body_mask("plane"))
    assert np.allclose(floor[:, 2], 0.0, atol=0.003)


def test_camera_renders_only_when_read(sim_factory: Any) -> None:
    sim = sim_factory({**scene(OVERHEAD), "sensors": {"cam": {"type": "camera", "rate_hz": 30, **OVERHEAD,
                                                              "width": 40, "height": 30}}})
    sim.step(240)  # one second: the camera was due 30 times but nobody looked
    assert sim.readings.computed("cam") == 0
    first = sim.readings["cam"]
    assert sim.readings["cam"] is first  # same tick: no second render
    assert sim.readings.computed("cam") == 1
    sim.step(1)  # tick 240 is due (period 8 ticks): a fresh frame on the next read
    second = sim.readings["cam"]
    assert second is not first and second.time > first.time
    sim.step(7)  # ticks 241..247 are not due: still the same frame
    assert sim.readings["cam"] is second
    assert sim.readings.computed("cam") == 2


def test_eye_in_hand_camera_follows_its_link(sim_factory: Any) -> None:
    # a camera mounted on a movable box's base, looking down (+z of the offset frame points down after the roll)
    config = scene({"mount_body": "rig", "mount_link": "link0", "offset_rpy_deg": [180, 0, 0],
                    "near": 0.05, "far": 3.0},
                   rig={"shape": "box", "size": [0.02, 0.02, 0.02], "mass": 0.0, "position": [0.0, 0.0, 0.6]})
    sim = sim_factory(config)
    frame = sim.readings["cam"]
    assert frame.eye == pytest.approx((0.0, 0.0, 0.6), abs=1e-6)
    # the rig's own box is at the eye (inside the near plane): the cube top is 0.5 m below
    assert frame.body_at(40, 30) == "cube"
    assert frame.depth[30, 40] == pytest.approx(0.5, abs=0.003)
    sim.world.set_pose("rig", (0.6, 0.0, 0.6))
    sim.step(1)
    moved = sim.readings["cam"]
    assert moved.eye == pytest.approx((0.6, 0.0, 0.6), abs=1e-6)
    assert moved.body_at(40, 30) == "plane"
    assert moved.depth[30, 40] == pytest.approx(0.6, abs=0.003)


def test_no_segmentation_when_switched_off(sim_factory: Any) -> None:
    sim = sim_factory(scene({**OVERHEAD, "segmentation": False}))
    frame = sim.readings["cam"]
    assert frame.segmentation is None and frame.body_at(40, 30) is None
    assert frame.depth[30, 40] == pytest.approx(0.9, abs=0.003)
