"""The World's contract, checked on every registered engine: what plugins and behaviours may rely on.

Each test builds a small scene, asks the World, and compares with an answer worked out independently (geometry,
Newton's laws, a finite difference). Tolerances allow for soft contacts and solver differences between engines;
units and frames are the ones ``robokit/engines/interface.py`` documents. An engine whose package is not installed
is skipped.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from robokit.engines.interface import ChainFrame, ChainJoint, World

GRAVITY = 9.81


def _engine_or_skip(name: str) -> type[World]:
    try:
        return World.engine_class(name)
    except ImportError as exc:
        pytest.skip(f"engine {name!r} not installed: {exc}")


@pytest.fixture(params=sorted(World.engines))
def world(request: pytest.FixtureRequest) -> Iterator[World]:
    cls = _engine_or_skip(request.param)
    with cls(seed=0) as w:
        w.load_urdf("plane", "plane.urdf")
        yield w


def _settle(world: World, seconds: float) -> None:
    for _ in range(round(seconds / world.time_step)):
        world.step()


def _rotation(q: tuple[float, ...] | list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _kuka(world: World) -> int:
    return world.load_urdf("kuka", "kuka_iiwa/model.urdf", fixed_base=True)


# ----------------------------------------------------------------- bodies, contacts
def test_a_resting_box_presses_on_the_plane_with_its_weight(world: World) -> None:
    box = world.add_primitive("box", "box", size=(0.2, 0.2, 0.2), mass=2.0, position=(0, 0, 0.3))
    _settle(world, 1.0)
    assert world.pose(box)[0][2] == pytest.approx(0.1, abs=0.005)
    points = world.contacts(box)
    assert points and {p.other for p in points} == {world.body("plane")}
    assert sum(p.normal_force for p in points) == pytest.approx(2.0 * GRAVITY, rel=0.05)
    assert all(p.normal[2] > 0.99 for p in points)  # from the plane (B) towards the box (A): up
    assert all(abs(p.position[2]) < 0.01 for p in points)  # on the plane's surface
    assert world.contacts(box, world.body("plane")) and not world.contacts(world.body("plane"), box, link=0)


def test_body_states_are_poses_and_velocities(world: World) -> None:
    ball = world.add_primitive("ball", "sphere", radius=0.05, mass=0.5, position=(0, 0, 2.0))
    _settle(world, 0.25)
    ((pos, orn, lin, ang),) = world.body_states([ball])
    assert (pos, orn) == world.pose(ball) and (lin, ang) == world.velocity(ball)
    assert lin[2] == pytest.approx(-GRAVITY * world.time, rel=0.02)  # free fall: v = g t


def test_mass_dynamics_colour_round_trip(world: World) -> None:
    box = world.add_primitive("box", "box", mass=1.5, position=(0, 0, 0.5), rgba=(1, 0, 0, 1))
    assert world.mass(box) == pytest.approx(1.5) and world.mass("plane") == 0
    world.set_dynamics(box, lateral_friction=0.7, restitution=0.3)
    got = world.dynamics(box)
    assert got["lateral_friction"] == pytest.approx(0.7) and got["restitution"] == pytest.approx(0.3)
    assert world.visual_rgba(box) == pytest.approx((1, 0, 0, 1))
    world.set_visual_rgba(box, (0, 0, 1, 1))
    assert world.visual_rgba(box) == pytest.approx((0, 0, 1, 1))


def test_penetration_and_disabled_collisions(world: World) -> None:
    a = world.add_primitive("a", "box", size=(0.2, 0.2, 0.2), mass=0, position=(0, 0, 1.0))
    b = world.add_primitive("b", "box", size=(0.2, 0.2, 0.2), mass=1, position=(0.17, 0, 1.0))
    assert world.penetration(a, b) == pytest.approx(0.03, abs=0.002)  # 0.2 wide, centres 0.17 apart
    ghost = world.add_primitive("ghost", "box", size=(0.1, 0.1, 0.1), mass=1, position=(2, 0, 0.2))
    world.disable_collisions(ghost)
    _settle(world, 1.0)
    assert world.pose(ghost)[0][2] < -1.0  # fell through the plane


# ----------------------------------------------------------------- joints
def test_joint_reset_and_the_three_motor_modes(world: World) -> None:
    kuka = _kuka(world)
    j = world.joint(kuka, "lbr_iiwa_joint_1").index
    world.reset_joint(kuka, j, 0.4)
    assert world.joint_states(kuka, [j])[0][0] == pytest.approx(0.4)
    world.set_joint_motor(kuka, j, "position", target_position=-0.3, force=300.0, position_gain=0.3)
    _settle(world, 1.5)
    assert world.joint_states(kuka, [j])[0][0] == pytest.approx(-0.3, abs=0.01)
    world.set_joint_motor(kuka, j, "velocity", force=0.0)  # motor off: the joint is passive
    before = world.joint_states(kuka, [j])[0][0]
    for _ in range(120):  # a torque about the vertical axis 1 spins the joint the torque's way
        world.set_joint_motors(kuka, [j], "torque", forces=[20.0])
        world.step()
    assert world.joint_states(kuka, [j])[0][0] > before + 0.1


def test_a_velocity_motor_reaches_its_target_velocity(world: World) -> None:
    kuka = _kuka(world)
    j = world.joint(kuka, "lbr_iiwa_joint_1").index
    world.set_joint_motors(kuka, [j], "velocity", target_velocities=[0.5], forces=[300.0])
    _settle(world, 0.5)
    assert world.joint_states(kuka, [j])[0][1] == pytest.approx(0.5, abs=0.02)


def test_joint_parents_walk_to_the_base(world: World) -> None:
    kuka = _kuka(world)
    ee = world.link(kuka, "lbr_iiwa_link_7")
    chain = [ee]
    while chain[-1] >= 0:
        chain.append(world.joint_parent(kuka, chain[-1]))
    assert chain == [6, 5, 4, 3, 2, 1, 0, -1]


def test_the_kinematic_chain_folds_to_the_link_pose(world: World) -> None:
    kuka = _kuka(world)
    q = [0.3, -0.5, 0.2, -1.2, 0.4, 0.8, -0.6]
    for index, value in enumerate(q):
        world.reset_joint(kuka, index, value)
    ee = world.link(kuka, "lbr_iiwa_link_7")
    frame = np.eye(4)
    for step in world.kinematic_chain(kuka, ee):
        move = np.eye(4)
        if isinstance(step, ChainFrame):
            move[:3, :3], move[:3, 3] = _rotation(step.orientation), step.position
        else:
            assert isinstance(step, ChainJoint) and step.type == "revolute"
            axis = np.asarray(step.axis, float) / np.linalg.norm(step.axis)
            angle = q[step.joint]
            k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            move[:3, :3] = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k  # Rodrigues
        frame = frame @ move
    pos, orn = world.pose(kuka, ee)
    assert frame[:3, 3] == pytest.approx(pos, abs=1e-6)  # (engines keep link poses in single precision)
    assert frame[:3, :3] == pytest.approx(_rotation(orn), abs=1e-6)


def test_the_jacobian_predicts_a_small_joint_motion(world: World) -> None:
    kuka = _kuka(world)
    q = np.array([0.3, -0.5, 0.2, -1.2, 0.4, 0.8, -0.6])
    ee = world.link(kuka, "lbr_iiwa_link_7")
    for index, value in enumerate(q):
        world.reset_joint(kuka, index, float(value))
    linear, _ = world.jacobian(kuka, ee, q.tolist())
    start = np.array(world.pose(kuka, ee)[0])
    dq = np.array([1, -2, 1, 0.5, -1, 2, 1]) * 1e-4
    for index, value in enumerate(q + dq):
        world.reset_joint(kuka, index, float(value))
    moved = np.array(world.pose(kuka, ee)[0]) - start
    assert np.abs(linear @ dq).max() > 1e-4  # the motion is far above the second-order error (|dq|² ~ 1e-8)
    assert moved == pytest.approx(linear @ dq, abs=2e-7)


@pytest.mark.skip_allowed("the contract lets an engine without IK of its own answer None (ik_arm then solves in numpy)")
def test_inverse_kinematics_answers_reach_the_target_or_say_none(world: World) -> None:
    kuka = _kuka(world)
    ee = world.link(kuka, "lbr_iiwa_link_7")
    target, down = (0.5, 0.1, 0.5), (1.0, 0.0, 0.0, 0.0)
    q = world.inverse_kinematics(kuka, ee, target, down, seed=[0.1, 0.3, 0.0, -1.2, 0.0, 1.0, 0.0],
                                 damping=[0.01] * 7, iterations=200, tolerance=1e-5)
    if q is None:
        pytest.skip(f"the {world.engine} engine has no IK of its own (ik_arm solves in numpy)")
    for index, value in enumerate(q):
        world.reset_joint(kuka, index, value)
    assert world.pose(kuka, ee)[0] == pytest.approx(target, abs=2e-3)


def test_a_joint_wrench_holds_up_what_hangs_below_it(world: World) -> None:
    kuka = _kuka(world)
    j = world.joint(kuka, "lbr_iiwa_joint_7").index
    world.enable_joint_wrench(kuka, j)
    for index in range(7):
        world.set_joint_motor(kuka, index, "position", target_position=0.0, force=500.0)
    _settle(world, 0.5)
    rot = np.asarray(world.wrench_frame(kuka, j)).reshape(3, 3)
    assert rot @ rot.T == pytest.approx(np.eye(3), abs=1e-9)
    force = rot @ np.asarray(world.joint_states(kuka, [j])[0][2][:3])
    assert abs(force[2]) == pytest.approx(world.mass(kuka, j) * GRAVITY, rel=0.1)  # link 7's weight, vertical


# ----------------------------------------------------------------- attachments
def test_an_attached_body_stays_and_falls_when_detached(world: World) -> None:
    post = world.add_primitive("post", "box", size=(0.1, 0.1, 0.1), mass=0, position=(0, 0, 1.0))
    box = world.add_primitive("box", "box", size=(0.1, 0.1, 0.1), mass=0.5, position=(0, 0, 0.85))
    held = world.attach(post, -1, box, max_force=500.0)
    assert world.joined(post, box)
    _settle(world, 0.5)
    assert world.pose(box)[0][2] == pytest.approx(0.85, abs=0.005)
    world.detach(held)
    assert not world.joined(post, box)
    _settle(world, 1.0)
    assert world.pose(box)[0][2] == pytest.approx(0.05, abs=0.005)


def test_coupled_fingers_mirror_each_other(world: World) -> None:
    panda = world.load_urdf("panda", "franka_panda/panda.urdf", fixed_base=True)
    a, b = (world.joint(panda, n).index for n in ("panda_finger_joint1", "panda_finger_joint2"))
    world.set_joint_motor(panda, b, "velocity", force=0.0)
    world.couple_joints(panda, a, b, 1.0, erp=0.8, max_force=50.0)
    world.set_joint_motor(panda, a, "position", target_position=0.03, force=20.0)
    _settle(world, 1.0)
    qa, qb = (s[0] for s in world.joint_states(panda, [a, b]))
    assert qa == pytest.approx(0.03, abs=2e-3) and qb == pytest.approx(qa, abs=2e-3)


# ----------------------------------------------------------------- rays, cameras
def test_rays_hit_what_geometry_says_and_look_through_hidden_bodies(world: World) -> None:
    box = world.add_primitive("box", "box", size=(0.2, 0.2, 0.2), mass=0, position=(1, 0, 0.1))
    starts = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [3.0, 3.0, 1.0]])
    ends = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [3.0, 3.0, 0.5]])
    hits = world.ray_caster().cast(starts, ends)
    assert hits.body.tolist() == [world.body("plane"), box, -1]
    assert hits.fraction == pytest.approx([0.5, 0.4, 1.0], abs=1e-3)  # plane at z = 0, box top at z = 0.2
    assert hits.position is not None and hits.position[1] == pytest.approx([1.0, 0.0, 0.2], abs=1e-3)
    assert hits.normal is not None and hits.normal[1] == pytest.approx([0, 0, 1], abs=1e-6)
    world.hide_from_rays(box)
    through = world.ray_caster(skip=(box,), see_hidden=False).cast(starts[1:2], ends[1:2])
    assert through.body.tolist() == [world.body("plane")] and through.fraction[0] == pytest.approx(0.5, abs=1e-3)


RAY_CORNERS = {
    # name: (start, end, what the ray reports: None for nothing, else (which body, fraction, normal))
    "starts inside, leaves": ((0.0, 0.0, 0.5), (1.0, 0.0, 0.5), None),
    "starts inside, meets the wall": ((0.0, 0.0, 0.5), (0.0, 1.0, 0.5), ("wall", 0.45, (0, -1, 0))),
    "starts on a face, points out": ((0.1, 0.0, 0.5), (1.0, 0.0, 0.5), None),
    "starts on a face, points in": ((0.1, 0.0, 0.5), (-1.0, 0.0, 0.5), ("box", 0.0, (1, 0, 0))),
    "from outside": ((-1.0, 0.0, 0.5), (1.0, 0.0, 0.5), ("box", 0.45, (-1, 0, 0))),
    "parallel to a face, 1 um outside": ((-1.0, 0.100001, 0.5), (1.0, 0.100001, 0.5), None),
    "parallel to a face, 1 mm inside": ((-1.0, 0.099, 0.5), (1.0, 0.099, 0.5), ("box", 0.45, (-1, 0, 0))),
    "ends on a face": ((-1.0, 0.0, 0.5), (-0.1, 0.0, 0.5), None),
    "ends 0.1 mm short": ((-1.0, 0.0, 0.5), (-0.1001, 0.0, 0.5), None),
    "ends 0.1 mm inside": ((-1.0, 0.0, 0.5), (-0.0999, 0.0, 0.5), ("box", 0.9 / 0.9001, (-1, 0, 0))),
    "zero length, outside": ((-1.0, 0.0, 0.5), (-1.0, 0.0, 0.5), None),
    "zero length, inside": ((0.0, 0.0, 0.5), (0.0, 0.0, 0.5), None),
    "through an edge": ((-1.0, -0.9, 0.5), (1.0, 1.1, 0.5), ("box", 0.45, None)),
}
"""A 0.2 m box centred at (0, 0, 0.5) and a wall whose near face is the plane y = 0.45: the answer per the rule in
:class:`~robokit.engines.interface.RayCaster` (a ray reports the first surface it enters; the shape it starts in is
passed through; the end is not part of the segment), worked out from the geometry."""


@pytest.mark.parametrize("batch", ["one start", "many starts"])
def test_rays_follow_the_worlds_rule_at_every_corner(world: World, batch: str) -> None:
    bodies = {"box": world.add_primitive("box", "box", size=(0.2, 0.2, 0.2), mass=0, position=(0, 0, 0.5)),
              "wall": world.add_primitive("wall", "box", size=(2, 0.1, 2), mass=0, position=(0, 0.5, 0.5))}
    cases = list(RAY_CORNERS.values())
    if batch == "one start":  # a lidar's batch: every ray from one point (engines may take a faster path)
        cases = [c for c in cases if c[0] == (0.0, 0.0, 0.5)]
    starts, ends = np.array([c[0] for c in cases]), np.array([c[1] for c in cases])
    hits = world.ray_caster().cast(starts, ends)
    for i, (_, _, expected) in enumerate(cases):
        name = [k for k, v in RAY_CORNERS.items() if v is cases[i]][0]
        if expected is None:
            assert (hits.body[i], hits.fraction[i]) == (-1, 1.0), name
            continue
        body, fraction, normal = expected
        assert hits.body[i] == bodies[body], name
        assert hits.fraction[i] == pytest.approx(fraction, abs=1e-6), name
        assert hits.position is not None and hits.normal is not None
        assert hits.position[i] == pytest.approx(starts[i] + fraction * (ends[i] - starts[i]), abs=1e-6), name
        if normal is not None:
            assert hits.normal[i] == pytest.approx(normal, abs=1e-6), name


def test_a_ray_inside_a_body_resting_on_the_floor_reads_what_is_beyond(world: World) -> None:
    """A range sensor inside a slab (mounted in it, or on a body sunk a little into it): its downward ray starts
    inside the slab and reports the plane it enters below, not the slab's face it leaves."""
    world.add_primitive("slab", "box", size=(0.4, 0.4, 0.1), mass=0, position=(0, 0, 0.05))
    hits = world.ray_caster().cast(np.array([[0.0, 0.0, 0.08]]), np.array([[0.0, 0.0, -1.0]]), detail=False)
    assert hits.body.tolist() == [world.body("plane")]
    assert hits.fraction[0] == pytest.approx(0.08 / 1.08, abs=1e-6)


def test_a_camera_sees_depth_in_metres_and_bodies_by_id(world: World) -> None:
    box = world.add_primitive("box", "box", size=(0.4, 0.4, 0.4), mass=0, position=(0, 0, 0.2), rgba=(1, 0, 0, 1))
    width, height, near, far = 64, 48, 0.1, 10.0
    view = world.view_matrix((0, 0, 2.0), (0, 0, 0), (0, 1, 0))
    projection = world.projection_matrix(60.0, width / height, near, far)
    image = world.render(width, height, view, projection, near=near, far=far)
    assert image.rgb.shape == (height, width, 3) and image.rgb.dtype == np.uint8
    assert image.segmentation is not None
    centre = (height // 2, width // 2)
    assert image.depth[centre] == pytest.approx(1.6, abs=0.02)  # the box top, 2.0 - 0.4 below the camera
    assert image.segmentation[centre] == box and image.segmentation[0, 0] == world.body("plane")
    assert image.depth[0, 0] == pytest.approx(2.0, abs=0.02)  # the plane: 2 m along the view axis everywhere
    red, green, blue = (int(v) for v in image.rgb[centre])
    assert red > 2 * max(green, blue)
    # the OpenGL matrices put a world point where the pinhole model says: the box's top corner (0.2, 0.2, 0.4)
    clip = np.asarray(projection).reshape(4, 4).T @ np.asarray(view).reshape(4, 4).T @ [0.2, 0.2, 0.4, 1.0]
    focal = 1.0 / math.tan(math.radians(60.0) / 2)
    assert clip[:2] / clip[3] == pytest.approx([focal / (width / height) * 0.2 / 1.6, focal * 0.2 / 1.6])


# ----------------------------------------------------------------- arithmetic, episodes, GUI
def test_pose_arithmetic(world: World) -> None:
    q = world.quaternion_from_euler((0.0, 0.0, math.pi / 2))
    assert world.euler_from_quaternion(q) == pytest.approx((0.0, 0.0, math.pi / 2))
    assert np.asarray(world.matrix_from_quaternion(q)).reshape(3, 3) == pytest.approx(_rotation(q))
    pos, orn = world.multiply_transforms((1, 0, 0), q, (1, 0, 0), (0, 0, 0, 1))
    assert pos == pytest.approx((1, 1, 0))
    back = world.multiply_transforms(*world.invert_transform((1, 0, 0), q), pos, orn)
    assert back[0] == pytest.approx((1, 0, 0)) and back[1] == pytest.approx((0, 0, 0, 1))


def test_snapshot_and_restore_put_everything_back(world: World) -> None:
    box = world.add_primitive("box", "box", mass=1, position=(0, 0, 1.0))
    kuka = _kuka(world)
    world.reset_joint(kuka, 1, 0.5)
    snapshot = world.snapshot()
    start = (world.pose(box), world.joint_states(kuka, [1])[0][0])
    _settle(world, 0.5)
    world.restore(snapshot)
    assert (world.pose(box), world.joint_states(kuka, [1])[0][0]) == start and world.tick == 0


def test_headless_drawing_and_keys_are_quiet(world: World) -> None:
    with world.drawing():
        world.debug_line((0, 0, 0), (1, 0, 0), (1, 0, 0), lifetime=0.1)
    assert dict(world.key_events()) == {}
    world.close()
    assert world.closed
