"""The colour detector against the rendered geometry, from generated camera poses.

The plugin promises (plugins/colour_detector.py, docs/vision.md): one detection per coloured blob of each colour
class, its world position (top face centre minus half of ``object_height``), footprint yaw (folded into a quarter
turn) and extent, and its pixel box. Here cubes of generated colours, sizes, places and yaws sit on a floor, seen by
a camera at a generated height, elevation, azimuth and roll about its optical axis (so the image is turned by an
arbitrary rotation, never only upright). The oracles: the world's poses of the cubes, and each cube's eight corners
projected into the image by a pinhole model written here from the camera's eye, target, up and field of view.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import Phase, assume, given, settings
from hypothesis import strategies as st

from robokit.core.world import yaw_of
from robokit.errors import ConfigError
from robokit.testing import make_sim

NO_SHRINK = [Phase.explicit, Phase.generate]  # an example is a simulation: a failing one is reported as drawn

COLOURS = {"red": [0.9, 0.05, 0.05, 1], "green": [0.1, 0.8, 0.1, 1], "blue": [0.1, 0.2, 0.9, 1],
           "yellow": [0.9, 0.85, 0.1, 1]}
W, H, FOV = 320, 240, 50.0


def project(points: np.ndarray, eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Pixel (u, v) of world points: camera axes from eye, target and up; vertical field of view FOV."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    rel = points - eye
    x, y, z = rel @ right, rel @ down, rel @ forward
    f = (H / 2) / math.tan(math.radians(FOV) / 2)  # focal length in pixels
    return np.stack([W / 2 + f * x / z, H / 2 + f * y / z], axis=1)


def corners(centre: np.ndarray, yaw: float, size: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    half = size / 2
    return np.array([centre + np.array([c * dx - s * dy, s * dx + c * dy, dz])
                     for dx in (-half, half) for dy in (-half, half) for dz in (-half, half)])


cube_st = st.tuples(st.floats(-0.22, 0.22), st.floats(-0.22, 0.22), st.floats(-math.pi, math.pi))


@settings(max_examples=6, deadline=None, derandomize=True, phases=NO_SHRINK)
@given(colours=st.lists(st.sampled_from(sorted(COLOURS)), min_size=1, max_size=4, unique=True),
       cubes=st.lists(cube_st, min_size=4, max_size=4), size=st.floats(0.04, 0.07),
       height=st.floats(0.7, 1.1), elevation=st.floats(65.0, 90.0), azimuth=st.floats(-180.0, 180.0),
       roll=st.floats(-180.0, 180.0))
def test_each_cube_is_found_where_the_world_and_the_image_geometry_say(
        colours: list[str], cubes: list[tuple], size: float, height: float, elevation: float, azimuth: float,
        roll: float) -> None:
    placed = dict(zip(colours, cubes, strict=False))
    spots = [np.array(c[:2]) for c in placed.values()]
    assume(all(np.linalg.norm(a - b) > 2.2 * size for i, a in enumerate(spots) for b in spots[i + 1:]))
    target = np.zeros(3)
    el, az, rl = (math.radians(v) for v in (elevation, azimuth, roll))
    eye = height * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    forward = (target - eye) / np.linalg.norm(target - eye)
    # an up vector perpendicular to the optical axis, turned by ``roll`` about it
    a = np.cross(forward, [0.0, 0.0, 1.0]) if abs(forward[2]) < 0.999 else np.array([1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(a, forward)
    up = math.cos(rl) * b + math.sin(rl) * a
    config: dict[str, Any] = {
        "bodies": {"floor": {"shape": "box", "size": [3, 3, 0.02], "mass": 0.0, "position": [0, 0, -0.01],
                             "rgba": [0.55, 0.55, 0.55, 1]}},
        "sensors": {
            "cam": {"type": "camera", "width": W, "height": H, "fov": FOV, "eye": eye.tolist(),
                    "target": target.tolist(), "up": up.tolist(), "renderer": "tiny", "segmentation": False},
            "det": {"type": "colour_detector", "camera": "cam", "object_height": size, "min_area": 8,
                    "open_px": 0},
        },
    }
    for name, (x, y, yaw) in placed.items():
        config["bodies"][name] = {"shape": "box", "size": [size] * 3, "mass": 0.0, "position": [x, y, size / 2],
                                  "rgba": COLOURS[name], "rpy_deg": [0.0, 0.0, math.degrees(yaw)]}
    with make_sim(config) as sim:
        sim.step(1)
        seen = sim.readings["det"]
        truth = {name: (np.asarray(sim.world.pose(name)[0]), yaw_of(sim.world.pose(name)[1])) for name in placed}
    assert sorted(d.colour for d in seen.items) == sorted(placed), "one detection per cube, nothing else"
    for d in seen.items:
        centre, yaw = truth[d.colour]
        assert np.linalg.norm(np.subtract(d.position, centre)) < 0.01, (d.colour, d.position, centre)
        assert d.top[2] == pytest.approx(size, abs=0.006)
        assert abs(math.remainder(d.yaw - yaw, math.pi / 2)) < math.radians(6), (d.colour, d.yaw, yaw)
        assert -math.pi / 4 - 1e-9 <= d.yaw < math.pi / 4
        pixel = 2 * math.tan(math.radians(FOV) / 2) * float(np.linalg.norm(eye - centre)) / H  # metres a pixel
        # the footprint is measured between pixel centres of the top face: up to a pixel and a half short
        assert size - 1.5 * pixel - 2e-3 <= d.extent[1] <= d.extent[0] <= size + 2e-3, (d.extent, size, pixel)
        pixels = project(corners(centre, yaw, size), eye, target, up)
        top = pixels[[1, 3, 5, 7]]  # dz = +half: the top face
        x, y, w, h = d.bbox
        lo, hi = pixels.min(axis=0), pixels.max(axis=0)
        # the blob lies within the cube's image and covers its top face's image (1.5 px for the raster's edges)
        assert lo[0] - 1.5 <= x and x + w <= hi[0] + 1.5 and lo[1] - 1.5 <= y and y + h <= hi[1] + 1.5, d.bbox
        assert x <= top[:, 0].min() + 1.5 and x + w >= top[:, 0].max() - 1.5, (d.bbox, top)
        assert y <= top[:, 1].min() + 1.5 and y + h >= top[:, 1].max() - 1.5, (d.bbox, top)
        assert x <= d.pixel[0] <= x + w and y <= d.pixel[1] <= y + h
        assert d.area <= w * h


def scene(detector: dict[str, Any]) -> dict[str, Any]:
    """A camera 1 m above the floor looking down, 20 frames a second; a big red cube at the centre and a red speck
    on either side of it along the image's rows (one is labelled before the cube, one after)."""
    bodies: dict[str, Any] = {"floor": {"shape": "box", "size": [3, 3, 0.02], "mass": 0.0, "position": [0, 0, -0.01],
                                        "rgba": [0.55, 0.55, 0.55, 1]}}
    for name, (x, y, size) in {"cube": (0.0, 0.0, 0.06), "speck_a": (0.0, 0.2, 0.008),
                               "speck_b": (0.0, -0.2, 0.008), "blue": (0.2, 0.0, 0.05)}.items():
        bodies[name] = {"shape": "box", "size": [size] * 3, "mass": 0.0, "position": [x, y, size / 2],
                        "rgba": COLOURS["blue" if name == "blue" else "red"]}
    return {"bodies": bodies,
            "sensors": {"cam": {"type": "camera", "width": W, "height": H, "fov": FOV, "eye": [0, 0, 1.0],
                                "target": [0, 0, 0], "up": [1, 0, 0], "renderer": "tiny", "segmentation": False,
                                "rate_hz": 20},
                        "det": {"type": "colour_detector", "camera": "cam", "object_height": 0.05,
                                "min_area": 12, **detector}}}


@pytest.mark.slow
def test_detections_follow_the_camera_frames_and_keep_every_blob_above_min_area() -> None:
    """Each reading names its camera and carries the time of the frame it was computed from (the camera's, 20
    frames a second, read every 5 physics ticks); the specks (about 4 px) are left out and the cube and the blue
    cube are found, wherever the specks come in the image's order."""
    with make_sim(scene({})) as sim:
        frame_times = set()
        for _ in range(6):
            sim.step(5)
            frame, det = sim.readings["cam"], sim.readings["det"]
            assert det.camera == "cam" and det.time == frame.time
            frame_times.add(frame.time)
            found = sorted((d.colour, round(d.position[0], 2), round(d.position[1], 2)) for d in det.items)
            assert found == [("blue", 0.2, 0.0), ("red", 0.0, 0.0)], found
        assert len(frame_times) >= 2


def test_an_unknown_camera_is_refused_at_its_key_naming_the_cameras_there_are() -> None:
    with pytest.raises(ConfigError, match=r"'eye'.*cam") as err:
        make_sim(scene({"camera": "eye"}))
    assert err.value.key == "sensors.det.camera"
