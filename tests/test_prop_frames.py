"""Frames and rotations, as properties over random rotations (never only the identity or 180 degrees).

Every pose helper robokit exposes -- the quaternion maths in ``robokit.msgs.arm``, the engines' pose arithmetic
(PyBullet and MuJoCo), link frames of a URDF robot at random joint angles, mount offsets of lidar and camera, the
camera's view/projection and ``deproject``, ``to_robot_frame``, forward kinematics -- is compared with an independent
computation written plainly here: rotation matrices from axis and angle (Rodrigues), Euler angles as the product
``Rz @ Ry @ Rx`` of fixed-axis rotations, frames composed as 4x4 matrices, rays met with a sphere in closed form.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import rodrigues
from robokit_behaviours.avoidance import to_robot_frame
from robokit_plugins.colour_detector import fold_yaw
from robokit_plugins.kinematics import Chain, quaternion_of, transform

from robokit.engines.interface import World
from robokit.engines.interface import yaw_of as engine_yaw_of
from robokit.msgs.arm import cube_grasp_yaw, down_quaternion, quat_angle, quat_multiply, yaw_of
from robokit.msgs.vision import deproject
from robokit.testing import PLANE, make_sim

PROPS = settings(max_examples=25, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
ENGINES = ["pybullet", "mujoco"]
DIFFBOT = Path(__file__).resolve().parents[1] / "robokit" / "data" / "robots" / "diffbot.urdf"


# ------------------------------------------------------------------------------------------ the oracle
def quat(axis: np.ndarray, angle: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` quaternion of a rotation by ``angle`` about ``axis``."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    s = math.sin(angle / 2.0)
    return (float(k[0] * s), float(k[1] * s), float(k[2] * s), math.cos(angle / 2.0))


X, Y, Z = np.eye(3)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Roll about fixed x, then pitch about fixed y, then yaw about fixed z (URDF's and PyBullet's convention)."""
    return rodrigues(Z, yaw) @ rodrigues(Y, pitch) @ rodrigues(X, roll)


def frame(position: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rotation, position
    return out


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (rad) of the rotation taking matrix ``a`` to matrix ``b``."""
    rel = a.T @ b
    return math.acos(max(-1.0, min(1.0, (np.trace(rel) - 1.0) / 2.0)))


def matrix_of(q: tuple[float, ...] | list[float]) -> np.ndarray:
    """Rotation matrix of a unit quaternion, through the axis and angle it encodes (not the product formula)."""
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-12:
        return np.eye(3)
    return rodrigues(np.array([x, y, z]), 2.0 * math.atan2(n, w))


def wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


# ------------------------------------------------------------------------------------------ strategies
unit = st.floats(-1.0, 1.0, allow_nan=False)
axes = st.tuples(unit, unit, unit).filter(lambda v: math.sqrt(sum(c * c for c in v)) > 0.1).map(np.array)
angles = st.floats(-math.pi, math.pi, allow_nan=False)
rotations = st.tuples(axes, angles)
positions = st.tuples(*(st.floats(-2.0, 2.0, allow_nan=False),) * 3).map(np.array)
# pitch away from +-90 degrees, where roll and yaw are not separate
euler = st.tuples(angles, st.floats(-1.45, 1.45), angles)


# ------------------------------------------------------------------------------------------ pure helpers
@PROPS
@given(rotations, rotations)
def test_quat_multiply_composes_rotations_a_then_b_as_matrices_do(a: tuple, b: tuple) -> None:
    qa, qb = quat(*a), quat(*b)
    expected = rodrigues(*a) @ rodrigues(*b)
    assert np.allclose(matrix_of(quat_multiply(qa, qb)), expected, atol=1e-9)


@PROPS
@given(angles)
def test_down_quaternion_points_the_tool_down_and_turns_it_by_yaw(yaw: float) -> None:
    r = matrix_of(down_quaternion(yaw))
    assert np.allclose(r @ Z, -Z, atol=1e-9)  # tool +z along world -z
    assert np.allclose(r @ X, [math.cos(yaw), math.sin(yaw), 0.0], atol=1e-9)  # finger axis turned by yaw
    assert np.allclose(r, rpy_matrix(math.pi, 0.0, yaw), atol=1e-9)


@PROPS
@given(rotations, rotations)
def test_quat_angle_is_the_angle_between_the_two_matrices(a: tuple, b: tuple) -> None:
    qa, qb = quat(*a), quat(*b)
    assert quat_angle(qa, qb) == pytest.approx(angle_between(rodrigues(*a), rodrigues(*b)), abs=1e-6)
    negated = tuple(-c for c in qb)  # -q is the same rotation
    assert quat_angle(qa, negated) == pytest.approx(quat_angle(qa, qb), abs=1e-9)  # type: ignore[arg-type]


@PROPS
@given(euler)
def test_yaw_of_reads_the_yaw_of_a_roll_pitch_yaw_rotation(rpy: tuple) -> None:
    r = rpy_matrix(*rpy)
    q = quaternion_of(r)
    heading = math.atan2(r[1, 0], r[0, 0])  # where the body's +x points, seen from above
    for f in (yaw_of, engine_yaw_of):
        assert wrap(f(q) - rpy[2]) == pytest.approx(0.0, abs=1e-7)
        assert wrap(f(q) - heading) == pytest.approx(0.0, abs=1e-7)
        assert -math.pi <= f(q) <= math.pi


@PROPS
@given(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0))
def test_cube_grasp_yaw_is_the_cube_symmetric_yaw_nearest_the_current_one(obj: float, current: float) -> None:
    got = cube_grasp_yaw(obj, current)
    quarter = math.pi / 2.0
    k = (got - obj) / quarter
    assert k == pytest.approx(round(k), abs=1e-9)  # a quarter turn of the cube away from its yaw
    best = min(abs(obj + j * quarter - current) for j in range(-20, 21))  # every candidate tried
    assert abs(got - current) == pytest.approx(best, abs=1e-9)


@PROPS
@given(st.floats(-720.0, 720.0))
def test_fold_yaw_keeps_the_rectangle_angle_modulo_a_quarter_turn(deg: float) -> None:
    got = fold_yaw(deg)
    assert -math.pi / 4 - 1e-12 <= got < math.pi / 4 + 1e-12
    k = (math.radians(deg) - got) / (math.pi / 2)
    assert k == pytest.approx(round(k), abs=1e-9)


@PROPS
@given(rotations, positions)
def test_kinematics_transform_and_quaternion_of_agree_with_axis_angle(rot: tuple, p: np.ndarray) -> None:
    q = quat(*rot)
    t = transform(p, q)
    assert np.allclose(t, frame(p, rodrigues(*rot)), atol=1e-9)
    back = quaternion_of(rodrigues(*rot))
    assert back[3] >= 0.0
    assert np.allclose(matrix_of(back), rodrigues(*rot), atol=1e-9)
    assert abs(float(np.dot(back, q))) == pytest.approx(1.0, abs=1e-9)  # q or -q


@PROPS
@given(st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), min_size=1, max_size=6),
       st.tuples(st.floats(-3, 3), st.floats(-3, 3), angles))
def test_to_robot_frame_inverts_placing_points_on_the_robot(points: list, pose: tuple) -> None:
    x, y, yaw = pose
    world_pts = np.array(points, float)
    local = to_robot_frame(world_pts, pose)
    heading = rodrigues(Z, yaw)[:2, :2]
    assert np.allclose(world_pts, local @ heading.T + [x, y], atol=1e-9)  # the robot puts them back


# ------------------------------------------------------------------------------------------ the engines
@pytest.fixture(scope="module", params=ENGINES)
def world(request: pytest.FixtureRequest) -> Iterator[World]:
    w = World.create(request.param, gravity=(0.0, 0.0, 0.0))
    w.load_urdf("robot", "robots/diffbot.urdf", position=(0, 0, 0.5))
    w.add_primitive("box", "box", size=(0.1, 0.2, 0.3), mass=1.0, position=(1, 1, 1))
    yield w
    w.close()


@PROPS
@given(rotations, positions, rotations, positions)
def test_engine_multiply_and_invert_transform_are_matrix_products(world: World, ra: tuple, pa: np.ndarray,
                                                                  rb: tuple, pb: np.ndarray) -> None:
    pos, orn = world.multiply_transforms(pa.tolist(), quat(*ra), pb.tolist(), quat(*rb))
    expected = frame(pa, rodrigues(*ra)) @ frame(pb, rodrigues(*rb))
    assert np.allclose(pos, expected[:3, 3], atol=1e-5)
    assert angle_between(matrix_of(orn), expected[:3, :3]) < 1e-5
    ipos, iorn = world.invert_transform(pa.tolist(), quat(*ra))
    inverse = np.linalg.inv(frame(pa, rodrigues(*ra)))
    assert np.allclose(ipos, inverse[:3, 3], atol=1e-5)
    assert angle_between(matrix_of(iorn), inverse[:3, :3]) < 1e-5


@PROPS
@given(euler, rotations)
def test_engine_euler_and_matrix_conversions(world: World, rpy: tuple, rot: tuple) -> None:
    q = world.quaternion_from_euler(list(rpy))
    assert angle_between(matrix_of(q), rpy_matrix(*rpy)) < 1e-5
    back = world.euler_from_quaternion(quat(*rot))
    assert angle_between(rpy_matrix(*back), rodrigues(*rot)) < 1e-5
    m = np.asarray(world.matrix_from_quaternion(quat(*rot)), float).reshape(3, 3)  # row by row
    assert np.allclose(m, rodrigues(*rot), atol=1e-5)


@PROPS
@given(rotations, positions)
def test_set_pose_pose_com_pose_and_box_corners(world: World, rot: tuple, p: np.ndarray) -> None:
    robot, box = world.body("robot"), world.body("box")
    world.set_pose(robot, p.tolist(), quat(*rot))
    pos, orn = world.pose(robot)
    assert np.allclose(pos, p, atol=1e-5) and angle_between(matrix_of(orn), rodrigues(*rot)) < 1e-5
    offset = world.link_offset(robot)
    assert offset is not None  # the diffbot's centre of mass sits 2 cm behind its link frame
    cpos, corn = world.com_pose(robot)
    composed = frame(np.array(cpos), matrix_of(corn)) @ frame(np.array(offset[0]), matrix_of(offset[1]))
    assert np.allclose(composed[:3, 3], p, atol=1e-5)  # pose = com_pose o link_offset
    assert angle_between(composed[:3, :3], rodrigues(*rot)) < 1e-5
    com_in_link = np.array([-0.02, 0.0, 0.0])  # <inertial><origin xyz="-0.02 0 0"> in diffbot.urdf
    assert np.allclose(cpos, p + rodrigues(*rot) @ com_in_link, atol=1e-5)
    state = world.body_states([robot])[0]
    assert np.allclose(state[0], pos, atol=1e-9) and np.allclose(state[1], orn, atol=1e-9)
    # a box turned by a random rotation: its bounding box spans its rotated corners
    world.set_pose(box, (p + 3.0).tolist(), quat(*rot))
    corners = np.array([[sx * 0.05, sy * 0.1, sz * 0.15] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    world_corners = corners @ rodrigues(*rot).T + (p + 3.0)
    lo, hi = world.aabb(box)
    assert np.allclose(lo, world_corners.min(axis=0), atol=2e-3)  # engines may pad by a margin (< 2 mm)
    assert np.allclose(hi, world_corners.max(axis=0), atol=2e-3)


def urdf_joints(path: Path) -> dict[str, dict]:
    """Child link -> joint origin (xyz, rpy), axis and type, read from the URDF file itself."""
    out = {}
    for j in ET.parse(path).getroot().iter("joint"):
        origin = j.find("origin")
        axis = j.find("axis")
        xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
        rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
        out[j.find("child").get("link")] = {  # type: ignore[union-attr]
            "name": j.get("name"), "type": j.get("type"), "xyz": np.array(xyz), "rpy": rpy,
            "axis": np.array([float(v) for v in (axis.get("xyz") if axis is not None else "1 0 0").split()]),
        }
    return out


@PROPS
@given(rotations, positions, st.lists(angles, min_size=3, max_size=3))
def test_link_frames_at_random_joint_angles_follow_the_urdf(world: World, rot: tuple, p: np.ndarray,
                                                           q: list[float]) -> None:
    robot = world.body("robot")
    world.set_pose(robot, p.tolist(), quat(*rot))
    moving = {"left_wheel": q[0], "right_wheel": q[1], "caster_wheel": q[2]}
    for name, value in moving.items():
        world.reset_joint(robot, world.joint(robot, name).index, value, 0.0)
    base = frame(p, rodrigues(*rot))
    for link, j in urdf_joints(DIFFBOT).items():
        motion = rodrigues(j["axis"], moving[j["name"]]) if j["type"] == "continuous" else np.eye(3)
        expected = base @ frame(j["xyz"], rpy_matrix(*j["rpy"])) @ frame(np.zeros(3), motion)
        pos, orn = world.pose(robot, world.link(robot, link))
        assert np.allclose(pos, expected[:3, 3], atol=1e-5), link
        assert angle_between(matrix_of(orn), expected[:3, :3]) < 1e-4, link


@PROPS
@given(rotations, positions, st.lists(angles, min_size=3, max_size=3))
def test_chain_fk_matches_the_engine_at_random_joint_angles(world: World, rot: tuple, p: np.ndarray,
                                                            q: list[float]) -> None:
    robot = world.body("robot")
    world.set_pose(robot, p.tolist(), quat(*rot))
    joints = [world.joint(robot, n).index for n in ("left_wheel", "right_wheel", "caster_wheel")]
    for index, value in zip(joints, q, strict=True):
        world.reset_joint(robot, index, value, 0.0)
    for link in ("left_wheel_link", "caster_link", "lidar_link"):
        chain = Chain(world, robot, world.link(robot, link), {j: i for i, j in enumerate(joints)})
        pos, orn = chain.fk(np.array(q))
        wpos, worn = world.pose(robot, world.link(robot, link))
        assert np.allclose(pos, wpos, atol=1e-5), link
        assert angle_between(matrix_of(orn), matrix_of(worn)) < 1e-4, link


# ------------------------------------------------------------------------------------------ camera
def pixel_of(point: np.ndarray, eye: np.ndarray, target: np.ndarray, up: np.ndarray, fov: float, w: int, h: int,
             sample_offset: float) -> tuple[float, float, float]:
    """Pinhole projection written from the camera's own axes: (u, v, depth along the optical axis)."""
    f = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, f)
    d = point - eye
    xc, yc, zc = float(d @ right), float(d @ true_up), float(d @ f)
    focal = 1.0 / math.tan(math.radians(fov) / 2.0)
    x_ndc, y_ndc = focal * (h / w) * xc / zc, focal * yc / zc
    return (x_ndc + 1.0) * w / 2.0 - sample_offset, (1.0 - y_ndc) * h / 2.0 - 1.0 + sample_offset, zc


@PROPS
@given(positions, rotations, st.floats(30.0, 90.0), st.floats(-0.8, 0.8), st.floats(-0.8, 0.8),
       st.floats(0.3, 4.0), st.sampled_from([0.0, 0.5]))
def test_deproject_inverts_the_pinhole_projection_of_the_engine_matrices(
        world: World, eye: np.ndarray, rot: tuple, fov: float, xn: float, yn: float, depth: float,
        offset: float) -> None:
    r = rodrigues(*rot)
    forward, up = r @ X, r @ Z  # a random camera: looking along its rotated +x, up along its rotated +z
    w, h = 64, 48
    focal = 1.0 / math.tan(math.radians(fov) / 2.0)
    right = np.cross(forward, up)
    # a point in view: at (xn, yn) in normalised image coordinates, ``depth`` along the optical axis
    point = eye + depth * (forward + xn * (w / h) / focal * right + yn / focal * up)
    u, v, zc = pixel_of(point, eye, eye + forward, up, fov, w, h, offset)
    assert zc == pytest.approx(depth)
    view = world.view_matrix(eye.tolist(), (eye + forward).tolist(), up.tolist())
    proj = world.projection_matrix(fov, w / h, 0.01, 10.0)
    back = deproject(np.array([u]), np.array([v]), np.array([depth]), view, proj, w, h, offset)
    assert np.allclose(back[0], point, atol=1e-4)


CAMERA_SCENE = {
    "bodies": {"plane": PLANE},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
    "sensors": {"cam": {"type": "camera", "width": 16, "height": 12, "mount_body": "robot",
                        "mount_link": "camera_link", "offset_xyz": [0.01, 0.02, 0.03],
                        "offset_rpy_deg": [-100.0, 20.0, -75.0]}},
}


@pytest.fixture(scope="module", params=ENGINES)
def camera_sim(request: pytest.FixtureRequest) -> Iterator:
    with make_sim(CAMERA_SCENE, overrides={"world.engine": request.param}) as sim:
        yield sim


@PROPS
@given(rotations, positions)
def test_mounted_camera_pose_follows_its_link_and_offset(camera_sim, rot: tuple, p: np.ndarray) -> None:
    world, cam = camera_sim.world, camera_sim.components["cam"]
    robot = world.body("robot")
    world.set_pose(robot, p.tolist(), quat(*rot))
    link_pos, link_orn = world.pose(robot, world.link(robot, "camera_link"))
    expected_link = frame(p, rodrigues(*rot)) @ frame(np.array([0.16, 0.0, 0.025]), np.eye(3))  # camera_mount
    assert np.allclose(link_pos, expected_link[:3, 3], atol=1e-5)
    offset = frame(np.array([0.01, 0.02, 0.03]), rpy_matrix(*np.radians([-100.0, 20.0, -75.0])))
    cam_frame = expected_link @ offset
    eye, target, up = (np.asarray(v, float) for v in cam.pose())
    assert np.allclose(eye, cam_frame[:3, 3], atol=1e-5)
    assert np.allclose(target - eye, cam_frame[:3, 2], atol=1e-5)  # looks along the offset frame's +z
    assert np.allclose(up, -cam_frame[:3, 1], atol=1e-5)  # image up is its -y
    # a point straight ahead is in view; the same point behind the camera is not
    assert cam.in_view(tuple(eye + 0.5 * cam_frame[:3, 2]))
    assert not cam.in_view(tuple(eye - 0.5 * cam_frame[:3, 2]))


# ------------------------------------------------------------------------------------------ lidar
def sphere_ranges(origin: np.ndarray, dirs: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Distance along each unit ray to a sphere's surface (inf: missed), closed form."""
    oc = origin - centre
    b = dirs @ oc
    disc = b * b - (oc @ oc - radius * radius)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc > 0) & (t > 0), t, np.inf)


LIDAR_SCENE = {
    "bodies": {"ball": {"shape": "sphere", "radius": 0.4, "mass": 0, "position": [1.5, 0, 0.37]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.3]}},
    "sensors": {"scan": {"type": "lidar", "rays": 72, "range_max": 4.0, "offset": [0.02, -0.03, 0.01],
                         "yaw_offset_deg": 35.0},
                "fixed": {"type": "lidar", "rays": 48, "fov_deg": 270.0, "range_max": 4.0,
                          "position": [0.0, 0.0, 0.0], "rpy_deg": [25.0, -40.0, 110.0]}},
}


@pytest.fixture(scope="module", params=ENGINES)
def lidar_sim(request: pytest.FixtureRequest) -> Iterator:
    with make_sim(LIDAR_SCENE, overrides={"world.engine": request.param}) as sim:
        yield sim


def check_scan(scan, origin: np.ndarray, rot: np.ndarray, centre: np.ndarray, first: float, inc: float) -> None:
    n = len(scan.ranges)
    a = first + inc * np.arange(n)
    dirs = np.stack([np.cos(a), np.sin(a), np.zeros(n)], axis=1) @ rot.T  # the sensor's xy-plane, in the world
    expected = sphere_ranges(origin, dirs, centre, 0.4)
    inner, outer = sphere_ranges(origin, dirs, centre, 0.39), sphere_ranges(origin, dirs, centre, 0.41)
    clear = np.isfinite(inner) & (np.abs(np.where(np.isfinite(inner), inner, 0.0) - expected) < 0.05)
    clear |= np.isinf(outer)  # not grazing the rim: a clear hit, or a clear miss
    assert np.allclose(scan.origin, origin, atol=1e-5)
    assert np.array_equal(np.isinf(scan.ranges[clear]), np.isinf(expected[clear]))
    hit = clear & np.isfinite(expected)
    assert hit.sum() >= 2  # the ball is in the scan
    assert np.allclose(scan.ranges[hit], expected[hit], atol=0.01)
    assert np.allclose(scan.points[hit], origin + dirs[hit] * expected[hit, None], atol=0.01)  # world frame


@PROPS
@given(rotations, st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), angles)
def test_lidar_rays_on_a_turned_robot_meet_a_sphere_where_geometry_says(lidar_sim, rot: tuple, dx: float, dy: float,
                                                                        ball_bearing: float) -> None:
    world = lidar_sim.world
    robot = world.body("robot")
    centre = np.array([1.5 * math.cos(ball_bearing) + dx, 1.5 * math.sin(ball_bearing) + dy, 0.37])
    world.set_pose("ball", centre.tolist())
    tilt = (rot[0], rot[1] * 0.06)  # tilted up to ~11 degrees: the scan plane still meets the ball
    world.set_pose(robot, [dx, dy, 0.3], quat(*tilt))
    base = frame(np.array([dx, dy, 0.3]), rodrigues(*tilt)) @ frame(np.array([0.06, 0.0, 0.06]), np.eye(3))
    origin = base[:3, :3] @ np.array([0.02, -0.03, 0.01]) + base[:3, 3]
    scan = lidar_sim.components["scan"].read()
    inc = 2 * math.pi / 72
    check_scan(scan, origin, base[:3, :3], centre, -math.pi + math.radians(35.0), inc)


@PROPS
@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_world_fixed_lidar_scans_in_its_rpy_plane(lidar_sim, a: float, b: float, c: float) -> None:
    world = lidar_sim.world
    world.set_pose("robot", [30.0, 30.0, 0.3])  # out of the way
    r = rpy_matrix(*np.radians([25.0, -40.0, 110.0]))
    # the ball somewhere near the sensor's scan plane, within 2 m
    centre = r @ np.array([1.6 * math.cos(2 * a), 1.6 * math.sin(2 * a), 0.2 * b]) + np.array([0.0, 0.0, 0.1 * c])
    world.set_pose("ball", centre.tolist())
    scan = lidar_sim.components["fixed"].read()
    fov = math.radians(270.0)
    check_scan(scan, np.zeros(3), r, centre, -fov / 2, fov / 47)


# ------------------------------------------------------------------------------------------ IK targets
ARM_SCENE = {
    "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {"arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget",
                          "ready_pose": {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8,
                                         "panda_joint7": 0.785}}},
}


@pytest.fixture(params=ENGINES)
def arm_engine(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(st.floats(0.35, 0.6), st.floats(-0.25, 0.25), st.floats(0.15, 0.45), st.floats(-1.4, 1.4),
       st.sampled_from(["down", "tilted"]), rotations)
def test_ik_arm_puts_the_tool_frame_at_the_target_pose(arm_engine: str, x: float, y: float, z: float, yaw: float,
                                                       kind: str, tilt: tuple) -> None:
    """A MoveTo's target frame: the tool's +z along world -z turned by ``yaw`` (``orientation`` None), or a given
    quaternion (the down pose tilted by up to ~17 degrees about a random axis). The world's link frame ends there.
    Each example starts from the arm's ready pose in a world of its own (a target's way depends on where it starts)."""
    with make_sim(ARM_SCENE, overrides={"world.engine": arm_engine}) as arm_sim:
        _check_target_pose(arm_sim, x, y, z, yaw, kind, tilt)


def _check_target_pose(arm_sim: Any, x: float, y: float, z: float, yaw: float, kind: str, tilt: tuple) -> None:
    from robokit.msgs.arm import MoveTo

    w, arm = arm_sim.world, arm_sim.components["arm"]
    down = rodrigues(Z, yaw) @ rodrigues(X, math.pi)  # tool down, turned by yaw about world +z
    if kind == "down":
        cmd, want = MoveTo((x, y, z), yaw=yaw), down
    else:
        want = rodrigues(tilt[0], tilt[1] * 0.1) @ down
        cmd = MoveTo((x, y, z), orientation=quaternion_of(want))
    arm.command(cmd)
    for _ in range(8):
        arm_sim.step(120)
        state = arm_sim.readings["arm"]
        if state.status != "moving":
            break
    assert state.status == "reached", state.reason
    panda = w.body("panda")
    pos, orn = w.pose(panda, w.link(panda, "panda_grasptarget"))
    cfg = arm.config  # ``reached`` promises the measured pose within the configured tolerances, no closer
    assert np.linalg.norm(np.subtract(pos, [x, y, z])) <= cfg.position_tolerance + 1e-6
    assert angle_between(matrix_of(orn), want) <= cfg.orientation_tolerance + 1e-6
    assert np.allclose(state.position, pos, atol=1e-4)  # the reading is the world's link frame
    assert math.degrees(angle_between(matrix_of(state.orientation), matrix_of(orn))) < 0.1
