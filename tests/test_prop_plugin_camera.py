"""The camera's promises (docs/vision.md) as properties over generated poses, judged by geometry and the world.

- ``in_view`` of points generated in the camera's own frame (inside, outside, behind, before near, past far) for a
  camera mounted with a generated offset on a body at a generated rotation (never one that is its own inverse):
  a pinhole frustum written here from the link's rotation (Rodrigues) and the offset's (``Rz @ Ry @ Rx``);
- a rendered frame from a generated fixed pose: the ball is seen at the pixel a plain pinhole projection puts its
  centre, at the depth the ray through it meets its surface; every ball pixel deprojects onto the ball and every floor
  pixel onto the floor (this also pins the renderer's sample offset); the frame's fields (eye, planes, time, the
  labels of every body in the mask) against the config and the world;
- ``save``: every rendered frame written as PNGs named by camera and tick, the RGB bytes equal to the frame's, the
  depth colour-mapped between the planes as the docs say, one colour per body and black background.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.testing import PLANE, make_sim


def rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


axes = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(lambda a: np.linalg.norm(a) > 0.2)
turns = st.one_of(st.floats(0.3, 2.8), st.floats(-2.8, -0.3))  # no rotation that is its own inverse
offsets = st.tuples(st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1))
rpys = st.tuples(st.floats(-170, 170), st.floats(-80, 80), st.floats(-170, 170))
# points in the camera's frame: (x / half-width, y / half-height, depth along the optical axis)
cam_points = st.lists(st.tuples(st.floats(-1.6, 1.6), st.floats(-1.6, 1.6), st.floats(-1.0, 6.0)), min_size=8,
                      max_size=8)


@pytest.mark.slow
@settings(max_examples=6, deadline=None, derandomize=True)
@given(axis=axes, angle=turns, offset=offsets, rpy=rpys, fov=st.floats(25, 100), size=st.sampled_from(
    [(32, 24), (24, 32), (40, 20)]), near=st.floats(0.05, 0.5), far=st.floats(1.0, 5.0), points=cam_points)
def test_in_view_is_the_pinhole_frustum_of_a_mounted_camera(axis: tuple, angle: float, offset: tuple, rpy: tuple,
                                                            fov: float, size: tuple[int, int], near: float,
                                                            far: float, points: list[tuple]) -> None:
    cfg = {"bodies": {"rig": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0, "position": [0, 0, 1]}},
           "sensors": {"cam": {"type": "camera", "width": size[0], "height": size[1], "fov": fov, "near": near,
                               "far": far, "mount_body": "rig", "mount_link": "base",
                               "offset_xyz": list(offset), "offset_rpy_deg": list(rpy)}}}
    with make_sim(cfg) as sim:
        w, cam = sim.world, sim.components["cam"]
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        where = np.array([0.3, -0.2, 1.1])
        w.set_pose("rig", where.tolist(), [*(a * math.sin(angle / 2)), math.cos(angle / 2)])
        rot = rodrigues(a, angle) @ rpy_matrix(*np.radians(rpy))  # the camera's axes: x right, y down, z forward
        eye = where + rodrigues(a, angle) @ np.asarray(offset)
        got_eye, target, up = cam.pose()
        assert np.allclose(got_eye, eye, atol=1e-6)
        assert np.allclose(np.subtract(target, got_eye), rot[:, 2], atol=1e-6)
        assert np.allclose(up, -rot[:, 1], atol=1e-6)
        half_h = math.tan(math.radians(fov) / 2)
        half_w = half_h * size[0] / size[1]
        # and on the optical axis just before the near plane and just past the far one
        for fx, fy, z in [*points, (0.3, -0.2, 0.8 * near), (-0.2, 0.3, 1.1 * far), (0.1, 0.1, 0.5 * (near + far))]:
            if min(abs(abs(fx) - 1), abs(abs(fy) - 1), abs(z - near), abs(z - far), abs(z)) < 1e-3:
                continue  # on a boundary: either answer is a rounding
            local = np.array([fx * half_w * z, fy * half_h * z, z]) if z > 0 else np.array([fx, fy, z])
            point = eye + rot @ local
            inside = z > 0 and abs(fx) <= 1 and abs(fy) <= 1 and near <= z <= far
            assert cam.in_view(tuple(point)) is inside, (fx, fy, z)


def sphere_point(azimuth: float, elevation: float, distance: float) -> np.ndarray:
    ce = math.cos(elevation)
    return distance * np.array([ce * math.cos(azimuth), ce * math.sin(azimuth), math.sin(elevation)])


@pytest.mark.slow
@settings(max_examples=12, deadline=None, derandomize=True)
@given(azimuth=st.floats(-math.pi, math.pi), elevation=st.floats(0.35, 1.2), distance=st.floats(0.9, 1.6),
       roll=st.floats(-0.6, 0.6), fov=st.floats(40, 75), ball=st.tuples(st.floats(-0.25, 0.25),
                                                                         st.floats(-0.25, 0.25), st.floats(0.1, 0.3)),
       radius=st.floats(0.07, 0.12), ticks=st.integers(0, 5))
def test_a_rendered_ball_is_where_the_pinhole_puts_it_and_its_pixels_deproject_onto_it(
        azimuth: float, elevation: float, distance: float, roll: float, fov: float, ball: tuple, radius: float,
        ticks: int) -> None:
    centre = np.asarray(ball, float)
    eye = sphere_point(azimuth, elevation, distance)
    target = np.zeros(3)
    f = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(f, [0, 0, 1])
    right /= np.linalg.norm(right)
    up = math.cos(roll) * np.cross(right, f) + math.sin(roll) * right  # turned about the optical axis
    width, height = 64, 48
    cfg = {"bodies": {"plane": PLANE, "ball": {"shape": "sphere", "radius": radius, "mass": 0,
                                               "position": centre.tolist()}},
           "sensors": {"cam": {"type": "camera", "width": width, "height": height, "fov": fov, "near": 0.05,
                               "far": 4.0, "eye": eye.tolist(), "target": target.tolist(), "up": up.tolist()}}}
    with make_sim(cfg) as sim:
        sim.step(ticks)
        w = sim.world
        frame = sim.readings["cam"]
        # the camera's own axes: x right, y up in the image, z forward
        cx = np.cross(f, up)
        cx /= np.linalg.norm(cx)
        cy = np.cross(cx, f)
        d = centre - eye
        xc, yc, zc = d @ cx, d @ cy, d @ f
        focal = 1 / math.tan(math.radians(fov) / 2)
        u = (focal * height / width * xc / zc + 1) * width / 2
        v = (1 - focal * yc / zc) * height / 2
        ui, vi = int(u), int(v)  # the pixel the centre's ray passes through
        assert frame.body_at(ui, vi) == "ball", (u, v)
        # the depths (along the optical axis) at which rays through that pixel's corners and centre meet the ball
        half = math.tan(math.radians(fov) / 2)
        depths = []
        for pu, pv in [(ui, vi), (ui + 1, vi), (ui, vi + 1), (ui + 1, vi + 1), (ui + 0.5, vi + 0.5)]:
            ray = f + (2 * pu / width - 1) * half * width / height * cx + (1 - 2 * pv / height) * half * cy
            b, c = ray @ (eye - centre), (eye - centre) @ (eye - centre) - radius ** 2
            a = ray @ ray
            depths.append((-b - math.sqrt(b * b - a * c)) / a)  # the nearer root: depth, as ray . f = 1
        # the rendered ball is a mesh whose facets lie inside the sphere by up to about a tenth of its radius
        assert min(depths) - 0.004 <= frame.depth[vi, ui] <= max(depths) + 0.004 + 0.1 * radius, (
            frame.depth[vi, ui], depths)
        on_ball = frame.points(frame.body_mask("ball"))
        assert len(on_ball) >= 4
        assert np.abs(np.linalg.norm(on_ball - centre, axis=1) - radius).max() < 0.004 + 0.1 * radius
        on_floor = frame.points(frame.body_mask("plane"))
        assert len(on_floor) > 100 and np.abs(on_floor[:, 2]).max() < 1e-3
        # the frame's fields
        assert np.allclose(frame.eye, eye, atol=1e-9) and frame.near == 0.05 and frame.far == 4.0
        assert frame.time == w.time
        assert frame.labels == {int(i): w.body_name(int(i)) for i in np.unique(frame.segmentation) if i >= 0}
        assert set(frame.labels.values()) == {"plane", "ball"}


def build_with_run_dir(run_dir: Path | None, save: bool, save_frames: bool, segmentation: bool = True) -> Any:
    from robokit.config import build_config
    from robokit.core.simulation import Simulation
    from robokit.plugin_api.plugins import load_plugins

    raw = {"bodies": {"plane": PLANE, "box": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 0,
                                              "position": [0, 0, 0.1], "rgba": [0.9, 0.2, 0.1, 1]}},
           "sensors": {"cam": {"type": "camera", "width": 40, "height": 30, "eye": [1.0, 0.6, 0.9],
                               "target": [0, 0, 0.1], "near": 0.1, "far": 3.0, "save": save,
                               "segmentation": segmentation}}}
    plugins = load_plugins(())
    cfg = build_config(raw, plugins, base_dir=Path.cwd())
    return Simulation(cfg, plugins, gui=False, run_dir=run_dir, save_frames=save_frames)


@pytest.mark.slow
@pytest.mark.parametrize(("save", "flag", "segmentation"), [(True, False, True), (False, True, True),
                                                             (True, False, False)])
def test_saved_frames_are_the_rendered_frames(tmp_path: Path, save: bool, flag: bool, segmentation: bool) -> None:
    import cv2

    sim = build_with_run_dir(tmp_path / "run", save, flag, segmentation)
    try:
        frames = {}
        for ticks in (0, 7, 30):
            sim.step(ticks)
            frames[sim.world.tick] = sim.readings["cam"]
    finally:
        sim.close()
    folder = tmp_path / "run" / "frames"
    kinds = ["depth", "rgb", "seg"] if segmentation else ["depth", "rgb"]
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        f"cam_{tick:06d}_{kind}.png" for tick in frames for kind in kinds)
    for tick, frame in frames.items():
        stem = folder / f"cam_{tick:06d}"
        rgb = cv2.imread(f"{stem}_rgb.png", cv2.IMREAD_UNCHANGED)
        assert np.array_equal(rgb[:, :, ::-1], frame.rgb)
        # depth: near (yellow) to far (dark blue) on viridis, between the frame's planes
        scaled = np.clip((frame.depth - frame.near) / (frame.far - frame.near), 0, 1)
        want = cv2.applyColorMap((255 * (1 - scaled)).astype(np.uint8), cv2.COLORMAP_VIRIDIS)
        assert np.array_equal(cv2.imread(f"{stem}_depth.png", cv2.IMREAD_UNCHANGED), want)
        if not segmentation:
            continue
        seg = cv2.imread(f"{stem}_seg.png", cv2.IMREAD_UNCHANGED).reshape(-1, 3)
        ids = frame.segmentation.reshape(-1)
        colours = {int(i): {tuple(c) for c in seg[ids == i]} for i in np.unique(ids)}
        assert all(len(c) == 1 for c in colours.values()), "one colour per body"
        assert len({next(iter(c)) for c in colours.values()}) == len(colours), "bodies in different colours"
        for i, c in colours.items():
            assert (next(iter(c)) == (0, 0, 0)) is (i < 0), "black is the background, and only it"


@pytest.mark.slow
def test_without_a_run_folder_or_a_wish_nothing_is_saved(tmp_path: Path) -> None:
    for run_dir, save, flag in [(None, True, True), (tmp_path / "run", False, False)]:
        sim = build_with_run_dir(run_dir, save, flag)
        try:
            sim.step(3)
            assert sim.readings["cam"].rgb.shape == (30, 40, 3)
        finally:
            sim.close()
        assert not (tmp_path / "run" / "frames").exists()


def test_a_mounted_camera_follows_its_link_at_rotations_about_several_axes() -> None:
    """One build, the mount turned to generated rotations about several axes at once (never a rotation that is its
    own inverse): eye, viewing direction (+z of the offset frame) and image up (its -y) from Rodrigues."""
    offset, rpy = (0.03, -0.02, 0.05), (35.0, -50.0, 120.0)
    cfg = {"bodies": {"rig": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0, "position": [0, 0, 1]}},
           "sensors": {"cam": {"type": "camera", "width": 16, "height": 12, "mount_body": "rig",
                               "mount_link": "base", "offset_xyz": list(offset), "offset_rpy_deg": list(rpy)}}}
    rng = np.random.default_rng(3)
    with make_sim(cfg) as sim:
        w, cam = sim.world, sim.components["cam"]
        for _ in range(12):
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            angle = float(rng.uniform(0.3, 2.8) * rng.choice([-1, 1]))
            where = rng.uniform(-1, 1, size=3)
            w.set_pose("rig", where.tolist(), [*(axis * math.sin(angle / 2)), math.cos(angle / 2)])
            link = rodrigues(axis, angle)
            rot = link @ rpy_matrix(*np.radians(rpy))
            eye, target, up = cam.pose()
            assert np.allclose(eye, where + link @ np.asarray(offset), atol=1e-6)
            assert np.allclose(np.subtract(target, eye), rot[:, 2], atol=1e-6)
            assert np.allclose(up, -rot[:, 1], atol=1e-6)
