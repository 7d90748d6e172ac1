"""``lidar`` against plain geometry: ranges and hit points on turned boxes, and the angles each ray goes out at.

Boxes -- one static box built as a triangle mesh (``collision = "mesh"``, intersected in numpy) and one ordinary
static box (cast by PyBullet) -- are set at generated places and turned about random axes, the robot carrying the
sensor at a generated pose, tilted a little. The oracle: the slab method, each ray met with each box in the box's
own frame (axes from the box's quaternion through axis and angle, Rodrigues), the nearest crossing between
``range_min`` and ``range_max``. Rays that graze an edge (the answer changes when the box grows or shrinks by 5 mm)
are left out of the comparison.

The scan's angles are figures the reading gives twice: ``angle_min``/``angle_max``/``angle_increment`` (and the
scan's ``yaw``) say where each ray went, and ``points`` say where it ended. Both are compared for fans of several
sizes (odd, even, one ray, a full circle that must not repeat its first ray, a partial field of view): every ray's
point lies at ``yaw + angle_min + i * angle_increment`` from the origin, at its range or at ``range_max``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import rotation
from robokit_plugins.lidar import scan_angles

from robokit.errors import ConfigError
from robokit.testing import make_sim

PROPS = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
BOXES = {"slab": (0.3, 1.2, 0.6), "block": (0.5, 0.25, 0.6)}
FANS = {  # name -> (rays, fov_deg, range_min, range_max, yaw_offset_deg)
    "scan": (90, 360.0, 0.05, 4.0, 20.0),
    "front": (31, 120.0, 0.1, 3.0, 0.0),
    "even": (8, 90.0, 0.05, 2.5, -30.0),
    "one": (1, 360.0, 0.05, 3.5, 45.0),
}
SCENE = {
    "bodies": {
        "slab": {"shape": "box", "size": list(BOXES["slab"]), "mass": 0, "collision": "mesh",
                 "position": [1.5, 0.0, 0.3]},
        "block": {"shape": "box", "size": list(BOXES["block"]), "mass": 0, "position": [0.0, 1.5, 0.3]},
    },
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.3]}},
    "sensors": {name: {"type": "lidar", "rays": rays, "fov_deg": fov, "range_min": rmin, "range_max": rmax,
                       "yaw_offset_deg": yaw}
                for name, (rays, fov, rmin, rmax, yaw) in FANS.items()},
}


@pytest.fixture(scope="module")
def sim() -> Iterator:
    with make_sim(SCENE) as s:
        yield s


def quat(axis: np.ndarray, angle: float) -> list[float]:
    k = np.asarray(axis, float) / np.linalg.norm(axis) * math.sin(angle / 2.0)
    return [float(k[0]), float(k[1]), float(k[2]), math.cos(angle / 2.0)]


def slab(origin: np.ndarray, dirs: np.ndarray, centre: np.ndarray, rot: np.ndarray, half: np.ndarray
         ) -> np.ndarray:
    """Per unit ray, the distance at which it enters the box (inf: it misses, or starts inside)."""
    o = rot.T @ (origin - centre)
    d = dirs @ rot  # each ray in the box's frame
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - o) / d
        t2 = (half - o) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (near > 0), near, np.inf)


def expected(origin: np.ndarray, dirs: np.ndarray, boxes: dict[str, tuple[np.ndarray, np.ndarray]], grow: float,
             rmin: float, rmax: float) -> np.ndarray:
    best = np.full(len(dirs), np.inf)
    for name, (centre, rot) in boxes.items():
        t = slab(origin, dirs, centre, rot, np.asarray(BOXES[name]) / 2.0 + grow)
        best = np.minimum(best, np.where((t >= rmin) & (t <= rmax), t, np.inf))
    return best


axes = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: math.sqrt(sum(c * c for c in v)) > 0.1).map(np.array)
place = st.tuples(st.floats(0.9, 2.2), st.floats(-math.pi, math.pi), st.floats(0.15, 0.45))  # distance, bearing, z


@PROPS
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi), axes, st.floats(0.0, 0.12),
       place, place, axes, st.floats(-math.pi, math.pi), axes, st.floats(-math.pi, math.pi))
def test_every_ray_meets_the_turned_boxes_where_the_slab_method_says(
        sim, x: float, y: float, yaw: float, tilt_axis: np.ndarray, tilt: float, slab_at: tuple, block_at: tuple,
        slab_axis: np.ndarray, slab_angle: float, block_axis: np.ndarray, block_angle: float) -> None:
    w = sim.world
    robot = w.body("robot")
    w.set_pose(robot, [x, y, 0.3], quat(np.array([0.0, 0.0, 1.0]), yaw) if tilt == 0 else
               _compose(quat(tilt_axis, tilt), quat(np.array([0.0, 0.0, 1.0]), yaw)))
    boxes = {}
    for name, (dist, bearing, z), axis, angle in (("slab", slab_at, slab_axis, slab_angle),
                                                  ("block", block_at, block_axis, block_angle)):
        if name == "block":
            bearing += math.pi  # the other side of the robot: both boxes in view
        centre = np.array([x + dist * math.cos(bearing), y + dist * math.sin(bearing), z])
        q = quat(axis, angle)
        w.set_pose(name, centre.tolist(), q)
        boxes[name] = (centre, rotation(q))
    pos, orn = w.pose(robot, w.link(robot, "lidar_link"))
    origin, r = np.asarray(pos, float), rotation(orn)
    for name, (rays, fov, rmin, rmax, yaw_off) in FANS.items():
        scan = sim.components[name].read()
        a = np.radians(yaw_off) + (
            [0.0] if rays == 1 else
            -math.pi + 2 * math.pi / rays * np.arange(rays) if fov == 360.0 else
            np.radians(-fov / 2 + fov / (rays - 1) * np.arange(rays)))
        dirs = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1) @ r.T
        want = expected(origin, dirs, boxes, 0.0, rmin, rmax)
        small = expected(origin, dirs, boxes, -0.005, rmin, rmax)
        big = expected(origin, dirs, boxes, 0.005, rmin, rmax)
        clear = np.isinf(small) == np.isinf(big)  # not grazing an edge, nor ending just at range_max
        clear &= np.isinf(want) | (np.abs(np.where(np.isfinite(small), small, 0) - want) < 0.05)
        assert np.allclose(scan.origin, origin, atol=1e-6)
        assert np.array_equal(np.isinf(scan.ranges[clear]), np.isinf(want[clear])), name
        hit = clear & np.isfinite(want)
        assert name != "scan" or hit.sum() >= 4  # the full circle sees both boxes
        assert np.allclose(scan.ranges[hit], want[hit], atol=0.005), name
        assert np.allclose(scan.points[hit], origin + dirs[hit] * want[hit, None], atol=0.005), name
        miss = clear & np.isinf(want)
        assert np.allclose(scan.points[miss], origin + dirs[miss] * rmax, atol=1e-6), name  # the ray's end


def _compose(a: list[float], b: list[float]) -> list[float]:
    """The rotation ``b`` then ``a``, as matrices: the quaternion of ``R(a) @ R(b)`` through its axis and angle."""
    m = rotation(a) @ rotation(b)
    angle = math.acos(max(-1.0, min(1.0, (np.trace(m) - 1.0) / 2.0)))
    axis = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    return [0.0, 0.0, 0.0, 1.0] if np.linalg.norm(axis) < 1e-12 else quat(axis, angle)


@PROPS
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi))
def test_each_ray_goes_out_at_the_angle_the_scan_states(sim, x: float, y: float, yaw: float) -> None:
    w = sim.world
    w.set_pose("robot", [x, y, 0.3], quat(np.array([0.0, 0.0, 1.0]), yaw))
    w.set_pose("slab", [x + 1.2, y, 0.3])
    w.set_pose("block", [x - 0.3, y - 1.0, 0.3])
    for name, (rays, fov, _rmin, rmax, yaw_off) in FANS.items():
        scan = sim.components[name].read()
        n = len(scan.ranges)
        assert n == rays
        assert math.isclose(scan.angle_max, scan.angle_min + (n - 1) * scan.angle_increment, abs_tol=1e-12)
        if rays == 1:
            assert scan.angle_min == scan.angle_max == 0.0
        elif fov == 360.0:  # a full circle, the last ray one step short of the first
            assert math.isclose(scan.angle_increment * n, 2 * math.pi)
            assert math.isclose(scan.angle_min, -math.pi)
        else:
            assert math.isclose(scan.angle_max - scan.angle_min, math.radians(fov))
            assert math.isclose(scan.angle_min, -math.radians(fov) / 2)
        assert math.isclose(math.remainder(scan.yaw - yaw - math.radians(yaw_off), 2 * math.pi), 0.0, abs_tol=1e-6)
        d = scan.points - np.asarray(scan.origin)
        bearing = np.arctan2(d[:, 1], d[:, 0])
        stated = scan.yaw + scan.angle_min + scan.angle_increment * np.arange(n)
        assert np.allclose(np.remainder(bearing - stated + math.pi, 2 * math.pi) - math.pi, 0.0, atol=1e-6), name
        dist = np.linalg.norm(d, axis=1)
        assert np.allclose(dist, np.where(np.isfinite(scan.ranges), scan.ranges, rmax), atol=1e-6), name
        assert np.all(np.abs(d[:, 2]) < 1e-6)  # a level robot scans a level plane


@pytest.mark.slow
def test_a_lidar_fixed_in_the_world_casts_from_its_pose_and_reports_its_heading() -> None:
    """A lidar on a stand (``position`` and ``rpy_deg``, no robot) at six generated orientations: every ray ends
    where the slab method meets the two boxes from the stand, along the sensor's own xy-plane (roll, then pitch,
    then yaw about the fixed axes, written here), and the scan's yaw is the heading of the sensor's x axis."""
    rng = np.random.default_rng(4)
    rays, rmax = 36, 4.0
    for _ in range(6):
        rpy = np.array([rng.uniform(-12, 12), rng.uniform(-12, 12), rng.uniform(-180, 180)])
        r, p, y = np.radians(rpy)
        rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
        ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
        rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
        rot = rz @ ry @ rx
        origin = np.array([0.1, -0.2, 0.3])
        scene = {"bodies": SCENE["bodies"],
                 "sensors": {"stand": {"type": "lidar", "rays": rays, "range_max": rmax,
                                       "position": origin.tolist(), "rpy_deg": rpy.tolist()}}}
        with make_sim(scene) as fixed:
            scan = fixed.components["stand"].read()
            boxes = {n: (np.asarray(fixed.world.pose(n)[0]), np.eye(3)) for n in BOXES}
        a = -math.pi + 2 * math.pi / rays * np.arange(rays)
        dirs = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1) @ rot.T
        want = expected(origin, dirs, boxes, 0.0, 0.05, rmax)
        clear = np.isinf(expected(origin, dirs, boxes, -0.005, 0.05, rmax)) == np.isinf(
            expected(origin, dirs, boxes, 0.005, 0.05, rmax))
        assert np.allclose(scan.origin, origin, atol=1e-9)
        assert scan.yaw == pytest.approx(math.atan2(rot[1, 0], rot[0, 0]), abs=1e-6)
        hit = clear & np.isfinite(want)
        assert hit.sum() >= 2
        assert np.array_equal(np.isinf(scan.ranges[clear]), np.isinf(want[clear]))
        assert np.allclose(scan.ranges[hit], want[hit], atol=0.005)
        assert np.allclose(scan.points[hit], origin + dirs[hit] * want[hit, None], atol=0.005)
    with pytest.raises(ConfigError, match="rover") as err:
        make_sim({"bodies": SCENE["bodies"], "sensors": {"scan": {"type": "lidar", "robot": "rover"}}})
    assert err.value.key == "sensors.scan.robot"


@pytest.mark.parametrize("rays", [1, 2, 7, 360])
@pytest.mark.parametrize("fov", [90.0, 270.0, 360.0])
def test_a_fans_stated_angles_agree_with_each_other(rays: int, fov: float) -> None:
    """The last ray's angle is the first plus (rays - 1) increments; a partial fan spans its field of view, a
    full circle stops one increment short of closing it; one ray points straight ahead."""
    amin, amax, inc = scan_angles(rays, fov)
    assert amax == pytest.approx(amin + (rays - 1) * inc, abs=1e-12)
    if rays == 1:
        assert amin == amax == 0.0
    elif fov < 360.0:
        assert (amin, amax) == pytest.approx((-math.radians(fov) / 2, math.radians(fov) / 2), abs=1e-12)
    else:
        assert amax + inc == pytest.approx(amin + 2 * math.pi, abs=1e-12)
