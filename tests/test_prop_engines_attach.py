"""Attachments and mounts on both engines, over generated poses, against frames composed by hand.

The World promises (``robokit.engines.interface.World.attach`` / ``mount``): ``attach`` without a position holds
the child's base where it is now relative to the parent's link; with a ``position`` it holds the child's centre of
mass at that point of the parent link's centre-of-mass frame, orientations aligned; ``mount`` first moves the
child's base link frame to ``position`` / ``orientation`` in the parent link's frame, then holds it there. Each
example has a parent link on a hinge about a generated axis and a child whose centre of mass sits off its link
origin in a turned inertial frame (both written into the URDFs here), placed at random rotations that are never the
identity nor a half turn; the hinge then turns by a generated angle and the child must follow. The expected frames
are composed with numpy from the URDF's numbers and the world's link poses (rotation matrices from axis and angle).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pytest
from engine_inputs import ENGINES, axes, turns
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import quaternion_of, rodrigues, rotation, rpy_matrix

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]

NO_SHRINK = [Phase.explicit, Phase.generate]


def frame(position, orientation) -> np.ndarray:
    """4x4 homogeneous frame of a pose (orientation ``(x, y, z, w)``)."""
    m = np.eye(4)
    m[:3, :3] = rotation(orientation)
    m[:3, 3] = position
    return m


def offset(xyz, rpy) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rpy_matrix(*rpy)
    m[:3, 3] = xyz
    return m


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (rad) of the rotation taking ``a`` to ``b`` (3x3)."""
    return math.acos(max(-1.0, min(1.0, (np.trace(a.T @ b) - 1.0) / 2.0)))


def holder_urdf(axis: tuple, joint_rpy: tuple, com: tuple, com_rpy: tuple) -> str:
    j = " ".join
    return f"""<?xml version="1.0"?>
<robot name="holder">
  <link name="base">
    <inertial><origin xyz="0 0 0"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="arm">
    <inertial><origin xyz="{j(map(str, com))}" rpy="{j(map(str, com_rpy))}"/><mass value="0.5"/>
      <inertia ixx="0.002" iyy="0.003" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.04 0.04 0.04"/></geometry></collision>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0.02 -0.03 0.4" rpy="{j(map(str, joint_rpy))}"/>
    <axis xyz="{j(map(str, axis))}"/><limit lower="-3" upper="3" effort="500" velocity="20"/>
  </joint>
</robot>
"""


def cargo_urdf(com: tuple, com_rpy: tuple) -> str:
    j = " ".join
    return f"""<?xml version="1.0"?>
<robot name="cargo">
  <link name="body">
    <inertial><origin xyz="{j(map(str, com))}" rpy="{j(map(str, com_rpy))}"/><mass value="0.1"/>
      <inertia ixx="0.0002" iyy="0.0003" izz="0.0004" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.03 0.03 0.03"/></geometry></collision>
  </link>
</robot>
"""


small = st.tuples(*(st.floats(-0.05, 0.05),) * 3)
angles = st.tuples(*(st.floats(-1.4, 1.4),) * 3)
reach = st.tuples(*(st.floats(-0.25, 0.25),) * 3).filter(lambda v: np.linalg.norm(v) > 0.1)


class Scene:
    """A holder (fixed base, its arm on a hinge held by a stiff motor) and a cargo body, built per example and
    removed after it."""

    def __init__(self, world: World, tmp: Path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy,
                 cargo_at: np.ndarray) -> None:
        self.world = world
        holder, cargo = holder_urdf(hinge_axis, joint_rpy, arm_com, arm_rpy), cargo_urdf(cargo_com, cargo_rpy)
        # a file per content: PyBullet keeps a URDF file's text by its path for the life of the client
        paths = [tmp / f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:16]}.urdf"
                 for name, text in (("holder", holder), ("cargo", cargo))]
        for path, text in zip(paths, (holder, cargo), strict=True):
            path.write_text(text, encoding="utf-8")
        self.holder = world.load_urdf("holder", str(paths[0]), position=(0.1, 0.2, 0.0),
                                      orientation=quaternion_of((1, 2, 3), 0.7), fixed_base=True)
        self.cargo = world.load_urdf("cargo", str(paths[1]), position=cargo_at[:3, 3],
                                     orientation=self._quat(cargo_at[:3, :3]))
        world.disable_collisions(self.cargo)
        self.hinge = world.joint(self.holder, "hinge").index
        self.arm_com = offset(arm_com, arm_rpy)  # the arm's inertial frame in its link frame
        self.cargo_com = offset(cargo_com, cargo_rpy)
        self.hold(0.0)

    @staticmethod
    def _quat(m: np.ndarray) -> tuple[float, float, float, float]:
        angle = math.acos(max(-1.0, min(1.0, (np.trace(m) - 1.0) / 2.0)))
        axis = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
        if np.linalg.norm(axis) < 1e-9:
            return (0.0, 0.0, 0.0, 1.0)
        return quaternion_of(axis, angle)

    def hold(self, angle: float) -> None:
        self.world.set_joint_motor(self.holder, self.hinge, "position", target_position=angle, force=500.0,
                                   position_gain=0.5)

    def arm(self) -> np.ndarray:
        return frame(*self.world.pose(self.holder, self.hinge))

    def cargo_frame(self) -> np.ndarray:
        return frame(*self.world.pose(self.cargo))

    def settle(self, seconds: float) -> None:
        for _ in range(round(seconds / self.world.time_step)):
            self.world.step()

    def remove(self) -> None:
        self.world.remove_body("cargo")
        self.world.remove_body("holder")


def assert_frame(got: np.ndarray, want: np.ndarray, metres: float, radians: float, what: str) -> None:
    assert np.linalg.norm(got[:3, 3] - want[:3, 3]) < metres, f"{what}: {got[:3, 3]} != {want[:3, 3]}"
    assert angle_between(got[:3, :3], want[:3, :3]) < radians, f"{what}: turned by " \
        f"{angle_between(got[:3, :3], want[:3, :3]):.4f} rad"


SETTINGS = dict(max_examples=8, deadline=None, derandomize=True, phases=NO_SHRINK,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@settings(**SETTINGS)
@given(hinge_axis=axes, joint_rpy=angles, arm_com=small, arm_rpy=angles, cargo_com=small, cargo_rpy=angles,
       where=reach, turn_axis=axes, turn=turns, swing=st.floats(0.4, 1.2))
def test_an_attached_body_keeps_its_pose_in_the_parent_link_as_the_link_turns(
        world: World, tmp_path: Path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, where,
        turn_axis, turn, swing) -> None:
    placed = np.eye(4)
    placed[:3, :3] = rodrigues(turn_axis, turn)
    placed[:3, 3] = np.array([0.1, 0.2, 0.0]) + rotation(quaternion_of((1, 2, 3), 0.7)) @ [0.02, -0.03, 0.4] \
        + np.asarray(where)
    scene = Scene(world, tmp_path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, placed)
    try:
        relative = np.linalg.inv(scene.arm()) @ scene.cargo_frame()  # the cargo's link frame in the arm's
        held = world.attach(scene.holder, scene.hinge, scene.cargo)
        assert world.joined(scene.holder, scene.cargo) and world.joined(scene.cargo, scene.holder)
        scene.settle(0.2)
        assert_frame(scene.cargo_frame(), scene.arm() @ relative, 3e-3, 0.03, "held as it was")
        scene.hold(swing)  # the hinge turns; the cargo must turn with the arm
        scene.settle(0.8)
        assert abs(world.joint_states(scene.holder, [scene.hinge])[0][0] - swing) < 0.05
        assert_frame(scene.cargo_frame(), scene.arm() @ relative, 3e-3, 0.03, "after the hinge turned")
        world.detach(held)
        assert not world.joined(scene.holder, scene.cargo)
        before = scene.cargo_frame()[2, 3]
        scene.settle(0.3)
        assert scene.cargo_frame()[2, 3] < before - 0.3  # let go: it falls (9.81 * 0.3^2 / 2 = 0.44 m)
    finally:
        scene.remove()


@settings(**SETTINGS)
@given(hinge_axis=axes, joint_rpy=angles, arm_com=small, arm_rpy=angles, cargo_com=small, cargo_rpy=angles,
       where=reach, turn_axis=axes, turn=turns)
def test_an_attachment_at_a_position_holds_the_centre_of_mass_there_aligned(
        world: World, tmp_path: Path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, where,
        turn_axis, turn) -> None:
    arm_at = np.array([0.1, 0.2, 0.0]) + rotation(quaternion_of((1, 2, 3), 0.7)) @ [0.02, -0.03, 0.4]
    placed = np.eye(4)
    placed[:3, :3] = rodrigues(turn_axis, turn)  # anywhere near: the attachment pulls it into place
    placed[:3, 3] = arm_at + np.asarray(where) + 0.01
    scene = Scene(world, tmp_path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, placed)
    try:
        world.attach(scene.holder, scene.hinge, scene.cargo, position=where)
        scene.settle(1.0)
        arm_centre = scene.arm() @ scene.arm_com  # the arm's centre-of-mass frame, from the URDF's numbers
        cargo_centre = scene.cargo_frame() @ scene.cargo_com
        want = arm_centre.copy()
        want[:3, 3] = arm_centre[:3, :3] @ np.asarray(where) + arm_centre[:3, 3]
        assert_frame(cargo_centre, want, 3e-3, 0.03, "centre of mass at the position, axes aligned")
    finally:
        scene.remove()


@settings(**SETTINGS)
@given(hinge_axis=axes, joint_rpy=angles, arm_com=small, arm_rpy=angles, cargo_com=small, cargo_rpy=angles,
       where=reach, turn_axis=axes, turn=turns, swing=st.floats(0.4, 1.2))
def test_a_mounted_body_sits_at_its_offset_in_the_link_frame(
        world: World, tmp_path: Path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, where,
        turn_axis, turn, swing) -> None:
    scene = Scene(world, tmp_path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy,
                  offset((1.0, 1.0, 1.0), (0.3, 0.2, 0.1)))
    try:
        mount = np.eye(4)
        mount[:3, :3] = rodrigues(turn_axis, turn)
        mount[:3, 3] = where
        world.mount("cargo", "holder", scene.hinge, position=where, orientation=quaternion_of(turn_axis, turn))
        assert world.mounts.get(scene.cargo) == scene.holder and world.joined(scene.holder, scene.cargo)
        assert_frame(scene.cargo_frame(), scene.arm() @ mount, 1e-6, 1e-6, "moved onto the mount")
        scene.hold(swing)
        scene.settle(0.8)
        assert_frame(scene.cargo_frame(), scene.arm() @ mount, 3e-3, 0.03, "after the hinge turned")
    finally:
        scene.remove()


@settings(max_examples=8, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(hinge_axis=axes, joint_rpy=angles, arm_com=small, arm_rpy=angles, cargo_com=small,
       cargo_rpy=st.one_of(st.just((0.0, 0.0, 0.0)), angles), turn_axis=axes, turn=turns,
       moved=st.tuples(*(st.floats(-0.5, 0.5),) * 3))
def test_the_centre_of_mass_frame_is_the_model_files_inertial_frame(
        world: World, tmp_path: Path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, turn_axis,
        turn, moved) -> None:
    """``com_pose`` is the link frame moved by the URDF's ``<inertial><origin xyz rpy>`` (as PyBullet reads it),
    ``link_offset`` its inverse, ``set_com_pose`` puts that frame and ``set_pose`` the link frame where they are
    told; whatever order the
    inertia's principal axes come in (the cargo's diagonal inertia 2e-4, 3e-4, 4e-4 is not sorted the way MuJoCo
    sorts principal axes)."""
    placed = np.eye(4)
    placed[:3, :3] = rodrigues(turn_axis, turn)
    placed[:3, 3] = (0.5, -0.5, 1.0)
    scene = Scene(world, tmp_path, hinge_axis, joint_rpy, arm_com, arm_rpy, cargo_com, cargo_rpy, placed)
    try:
        assert_frame(frame(*world.com_pose(scene.holder, scene.hinge)), scene.arm() @ scene.arm_com, 1e-6, 1e-5,
                     "the arm's centre-of-mass frame")
        assert_frame(frame(*world.com_pose(scene.cargo)), placed @ scene.cargo_com, 1e-6, 1e-5,
                     "the cargo's centre-of-mass frame")
        link_offset = world.link_offset(scene.cargo)
        assert link_offset is not None
        assert_frame(frame(*link_offset), np.linalg.inv(scene.cargo_com), 1e-6, 1e-5, "link_offset")
        target = placed @ scene.cargo_com
        target[:3, 3] += moved
        target[:3, :3] = rodrigues(turn_axis, -turn) @ target[:3, :3]
        world.set_com_pose(scene.cargo, target[:3, 3], Scene._quat(target[:3, :3]))
        assert_frame(frame(*world.com_pose(scene.cargo)), target, 1e-6, 1e-5, "set_com_pose")
        assert_frame(scene.cargo_frame(), target @ np.linalg.inv(scene.cargo_com), 1e-6, 1e-5,
                     "the link frame after set_com_pose")
        # set_pose places the link frame (what pose reports), the centre of mass follows at its URDF offset
        target[:3, :3] = rodrigues(turn_axis, 0.5 * turn) @ target[:3, :3]
        target[:3, 3] -= moved
        world.set_pose(scene.cargo, target[:3, 3], Scene._quat(target[:3, :3]))
        assert_frame(scene.cargo_frame(), target, 1e-6, 1e-5, "set_pose")
        assert_frame(frame(*world.com_pose(scene.cargo)), target @ scene.cargo_com, 1e-6, 1e-5,
                     "the centre of mass after set_pose")
    finally:
        scene.remove()


@pytest.mark.parametrize("max_force", [None, 2000.0, 0.5])
def test_a_pybullet_attachment_holds_up_to_its_max_force(max_force: float | None) -> None:
    """``attach``'s ``max_force`` bounds the force holding the child (PyBullet; MuJoCo's weld is soft and takes no
    limit, docs/engines.md): a 0.5 kg box (4.9 N) hanging from a post is held by the default and by 2000 N, and
    sinks away under a 0.5 N limit."""
    try:
        cls = World.engine_class("pybullet")
    except ImportError as exc:
        pytest.skip(f"engine 'pybullet' not installed: {exc}")
    with cls(seed=0) as world:
        post = world.add_primitive("post", "box", size=(0.1, 0.1, 0.1), mass=0, position=(0, 0, 1.0),
                                   orientation=quaternion_of((1, 1, 0), 0.6))
        box = world.add_primitive("box", "box", size=(0.1, 0.1, 0.1), mass=0.5, position=(0.05, 0.02, 0.8),
                                  orientation=quaternion_of((0, 1, 1), 1.1))
        world.attach(post, -1, box, max_force=max_force)
        for _ in range(120):
            world.step()
        drop = 0.8 - world.pose(box)[0][2]
        assert drop > 0.05 if max_force == 0.5 else abs(drop) < 0.003, drop


@pytest.mark.parametrize("engine", ENGINES)
def test_two_attachments_are_told_apart(engine: str) -> None:
    """Two boxes attached to one post (one where it is, one at a position in the post's centre-of-mass frame)
    get their own ids: detaching the first lets only the first fall; the second sits where it was put."""
    try:
        cls = World.engine_class(engine)
    except ImportError as exc:
        pytest.skip(f"engine {engine!r} not installed: {exc}")
    with cls(seed=0) as world:
        turn = quaternion_of((1, 2, 0), 0.7)
        post = world.add_primitive("post", "box", size=(0.1, 0.1, 0.1), mass=0, position=(0, 0, 1.0), orientation=turn)
        first = world.add_primitive("first", "box", size=(0.05, 0.05, 0.05), mass=0.2, position=(0.0, 0.2, 0.9))
        second = world.add_primitive("second", "sphere", radius=0.03, mass=0.2, position=(0.3, 0.0, 1.0))
        a = world.attach(post, -1, first)
        b = world.attach(post, -1, second, position=(0.2, 0.05, -0.1))
        assert a != b and world.joined(post, first) and world.joined(post, second)
        for _ in range(60):
            world.step()
        world.detach(a)
        assert not world.joined(post, first) and world.joined(post, second)
        for _ in range(120):
            world.step()
        assert world.pose(first)[0][2] < 0.5  # let go: it fell
        held = frame((0, 0, 1.0), turn) @ np.array([0.2, 0.05, -0.1, 1.0])  # the post's centre of mass frame
        assert np.linalg.norm(np.asarray(world.pose(second)[0]) - held[:3]) < 3e-3
        assert angle_between(rotation(world.pose(second)[1]), rotation(turn)) < 0.03  # aligned with the post
