"""camera promises from the pinhole model: metric depth along the optical axis, the horizontal field of view set by
the aspect ratio, the far plane in in_view, a mounted camera's image-up direction (camera +y points down the image)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robokit.testing import PLANE, make_sim


def down_camera(**cam: object) -> dict:
    return {"bodies": {"plane": PLANE,
                       "cube": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 0, "position": [0.6, 0, 0.1]}},
            "sensors": {"cam": {"type": "camera", "width": 32, "height": 24, "eye": [0, 0, 1.0],
                                "target": [0, 0, 0], "up": [1, 0, 0], "near": 0.1, "far": 4.0, **cam}}}


def test_depth_is_metric_distance_along_the_optical_axis() -> None:
    """1 m above the floor looking straight down: depth 1.0 m at the centre pixels (TinyRenderer samples corners:
    the four around the centre), within a few mm."""
    with make_sim(down_camera()) as sim:
        frame = sim.readings["cam"]
    centre = frame.depth[11:13, 15:17]
    assert np.allclose(centre, 1.0, atol=0.01)


def test_horizontal_field_of_view_follows_the_aspect_ratio() -> None:
    """fov 60 deg vertical on a 64 x 32 image: the horizontal half-angle is atan(tan 30 deg * 2) = 49.1 deg. A point
    45 deg to the side is in view, one 52 deg to the side is not; 25 deg up or down is, 35 deg is not."""
    cfg = {"sensors": {"cam": {"type": "camera", "width": 64, "height": 32, "fov": 60.0, "eye": [0, 0, 1],
                               "target": [1, 0, 1], "up": [0, 0, 1], "near": 0.1, "far": 10.0}}}
    with make_sim(cfg) as sim:
        cam = sim.components["cam"]

        def at(azimuth_deg: float, elevation_deg: float) -> tuple[float, float, float]:
            """1 m ahead, turned azimuth to the left and elevation up (pinhole: tangents on the image plane)."""
            return (1.0, math.tan(math.radians(azimuth_deg)), 1.0 + math.tan(math.radians(elevation_deg)))

        assert math.degrees(math.atan(math.tan(math.radians(30)) * 2)) == pytest.approx(49.1, abs=0.05)
        assert cam.in_view(at(45, 0)) and cam.in_view(at(-45, 0))
        assert not cam.in_view(at(52, 0)) and not cam.in_view(at(-52, 0))
        assert cam.in_view((1.0, 0.0, 1.0 + math.tan(math.radians(25))))
        assert not cam.in_view((1.0, 0.0, 1.0 + math.tan(math.radians(35))))


def test_in_view_stops_at_the_far_plane() -> None:
    cfg = {"sensors": {"cam": {"type": "camera", "width": 32, "height": 24, "eye": [0, 0, 1], "target": [1, 0, 1],
                               "up": [0, 0, 1], "near": 0.1, "far": 3.0}}}
    with make_sim(cfg) as sim:
        cam = sim.components["cam"]
        assert cam.in_view((2.9, 0.0, 1.0))
        assert not cam.in_view((3.1, 0.0, 1.0)) and not cam.in_view((0.05, 0.0, 1.0))


def test_a_mounted_camera_looks_along_its_z_with_image_up_along_minus_y() -> None:
    """Mounted on an unrotated static box: the camera's +z (forward) is world +z, its +y points down the image, so
    the view's up vector is world -y."""
    cfg = {"bodies": {"post": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0, "position": [0, 0, 1]}},
           "sensors": {"cam": {"type": "camera", "width": 16, "height": 16, "mount_body": "post",
                               "mount_link": "base", "offset_xyz": [0, 0, 0.1]}}}
    with make_sim(cfg) as sim:
        eye, target, up = sim.components["cam"].pose()
    assert eye == pytest.approx((0, 0, 1.1))
    assert np.subtract(target, eye) == pytest.approx((0, 0, 1))
    assert up == pytest.approx((0, -1, 0))
