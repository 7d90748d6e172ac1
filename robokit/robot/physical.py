"""The checks that load the robot into PyBullet (a DIRECT client of their own, closed at the end).

- ``inertia-scale``: each link's inertia against that of a solid box filling its collision shapes' bounding box
  with the same mass; a factor of :data:`SCALE_FACTOR` off either way is a unit mistake, not a design.
- ``overlap``: collision shapes of two links that are not parent and child (nor joined by fixed joints into one
  rigid piece) interpenetrating by more than :data:`OVERLAP` at the zero pose.
- ``wheels``: a wheel (a continuous joint's cylinder) sunk into its own parent (the chassis).
- ``stability``: a mobile base dropped on a plane stands for :data:`STAND_TIME` seconds, tilted at most
  :data:`MAX_TILT_DEG`, on its wheels (its base link off the ground).
"""

from __future__ import annotations

import math
from itertools import combinations
from typing import Any

import numpy as np

from robokit.robot.model import Robot
from robokit.robot.problem import Problem, is_mobile

SCALE_FACTOR = 20.0
OVERLAP = 0.003
"""Metres of interpenetration allowed between two links at the zero pose."""
STAND_TIME = 1.0
MAX_TILT_DEG = 10.0
WHEEL_INSIDE = 0.75
"""How deep a wheel may sink into its parent, as a share of its width (Husky's chassis box: 58 mm of 114 mm)."""
MIN_TIP_DEG = 3.0
"""A base resting on its chassis tilted more than this has tipped over (less: its wheels are too small)."""


def _client() -> Any:
    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    return BulletClient(connection_mode=pybullet.DIRECT)


def physical_problems(robot: Robot, *, fixed_base: bool | None = None) -> list[Problem]:
    """Load the robot (fixed at the origin, zero pose) and run the physical checks."""
    from robokit.process.quiet import quiet_stdout

    with quiet_stdout():  # PyBullet prints warnings (missing inertials) at C level: the checks say what matters
        return _physical(robot, fixed_base)


def _physical(robot: Robot, fixed_base: bool | None) -> list[Problem]:
    import pybullet

    client = _client()
    try:
        try:
            body = client.loadURDF(str(robot.path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        except pybullet.error as exc:
            return [Problem("load", f"robot {robot.name!r}", f"PyBullet cannot load it ({exc})",
                            "fix the problems above; check the file with an XML viewer")]
        index = dict(_link_indices(client, body))
        out = _scale(robot, client, body, index)
        twin = client.loadURDF(str(robot.path), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        out += _overlaps(robot, client, (body, twin), index)
        if is_mobile(robot, fixed_base):
            out += _stands(robot, client)
        return out
    finally:
        client.disconnect()


def _link_indices(client: Any, body: int) -> list[tuple[str, int]]:
    out = [(client.getBodyInfo(body)[0].decode(), -1)]
    for i in range(client.getNumJoints(body)):
        out.append((client.getJointInfo(body, i)[12].decode(), i))
    return out


def _scale(robot: Robot, client: Any, body: int, index: dict[str, int]) -> list[Problem]:
    out = []
    for link in robot.links:
        if not link.mass or link.mass <= 0 or link.inertia is None or not link.collisions or link.name not in index:
            continue
        lo, hi = client.getAABB(body, index[link.name])
        size = np.maximum(np.subtract(hi, lo), 1e-3)
        box = link.mass * float(np.sum(size ** 2)) / 6.0  # trace of a solid box's inertia: m (a² + b² + c²) / 6
        given = link.inertia[0] + link.inertia[3] + link.inertia[5]
        ratio = given / box
        if ratio > SCALE_FACTOR or ratio < 1.0 / SCALE_FACTOR:
            a, b, c = (float(v) for v in size)
            m = link.mass
            solid = f"ixx = {m * (b * b + c * c) / 12:.3g}, iyy = {m * (a * a + c * c) / 12:.3g}, " \
                    f"izz = {m * (a * a + b * b) / 12:.3g}"
            out.append(Problem(
                "inertia-scale", f"link {link.name!r}",
                f"its inertia (ixx + iyy + izz = {given:.3g} kg·m²) is {ratio:.3g} times that of a solid "
                f"{a:.2g} x {b:.2g} x {c:.2g} m box of {m:g} kg (its collision size)",
                f"check the units (kg·m², not g·cm²) and the formula: a solid box has {solid}",
                link.line, warning=True))
    return out


def _rigid_groups(robot: Robot) -> dict[str, str]:
    """Link -> the first link of the rigid piece it belongs to (links joined by fixed joints are one piece)."""
    group = {lk.name: lk.name for lk in robot.links}

    def find(name: str) -> str:
        while group[name] != name:
            name = group[name]
        return name

    for j in robot.joints:
        if j.type == "fixed" and j.parent in group and j.child in group:
            group[find(j.child)] = find(j.parent)
    return {name: find(name) for name in group}


def _adjacent(robot: Robot, groups: dict[str, str]) -> tuple[set[frozenset[str]], set[frozenset[str]]]:
    """Pairs of rigid pieces joined by one moving joint (parent and child), and by two in a chain (grandparent and
    grandchild: an arm's links two joints apart meet at the middle joint's housing)."""
    parent = {groups[j.child]: groups[j.parent] for j in robot.joints
              if j.parent in groups and j.child in groups and groups[j.child] != groups[j.parent]}
    pairs = {frozenset((c, p)) for c, p in parent.items()}
    chains = {frozenset((c, parent[p])) for c, p in parent.items() if p in parent}
    return pairs, chains


def _depth(client: Any, bodies: tuple[int, int], a: int, b: int) -> float:
    """Interpenetration (m, 0 if apart) of link ``a`` and link ``b``: measured between the robot and its twin
    (a second copy at the same pose), since PyBullet reports no closest points between links of one body."""
    points = client.getClosestPoints(bodies[0], bodies[1], 0.0, linkIndexA=a, linkIndexB=b)
    return max((-p[8] for p in points), default=0.0)


def _overlaps(robot: Robot, client: Any, bodies: tuple[int, int], index: dict[str, int]) -> list[Problem]:
    groups = _rigid_groups(robot)
    adjacent, chains = _adjacent(robot, groups)
    colliding = [lk.name for lk in robot.links if lk.collisions and lk.name in index]
    out = []
    for a, b in combinations(colliding, 2):
        ga, gb = groups[a], groups[b]
        if ga == gb:
            continue
        depth = _depth(client, bodies, index[a], index[b])
        if depth <= OVERLAP or frozenset((ga, gb)) in chains:
            continue
        if frozenset((ga, gb)) in adjacent:
            out += _wheel_in_parent(robot, (a, b), depth)
            continue
        link = robot.link(b)
        out.append(Problem("overlap", f"links {a!r} and {b!r}", f"their collision shapes overlap by "
                           f"{depth * 1000:.0f} mm at the zero pose (they are not parent and child)",
                           "move one of them apart (joint origins, shape sizes) so they do not touch at rest",
                           link.line if link else 0))
    return out


def _wheel_in_parent(robot: Robot, pair: tuple[str, str], depth: float) -> list[Problem]:
    """A wheel sunk into its parent (the chassis) deeper than :data:`WHEEL_INSIDE` of its width. PyBullet ignores
    the contact, but the robot is built wrong (a chassis box that grazes the wheels, as Husky's does, is fine)."""
    for j in robot.joints:
        if j.type != "continuous" or {j.parent, j.child} != set(pair):
            continue
        child = robot.link(j.child)
        widths = [s.size[1] for s in (child.collisions if child else []) if s.kind == "cylinder"]
        if not widths or depth <= WHEEL_INSIDE * max(widths):
            return []
        return [Problem("wheels", f"joint {j.name!r}", f"wheel {j.child!r} is sunk {depth * 1000:.0f} mm into "
                        f"{j.parent!r} at rest (the wheel is {max(widths) * 1000:.0f} mm wide)",
                        "move the wheel out (a wider track) or make the chassis narrower: track > chassis width + "
                        "wheel width", j.line)]
    return []


def _stands(robot: Robot, client: Any) -> list[Problem]:
    """Drop the free robot onto a plane from just above it; after STAND_TIME s it must be upright on its wheels."""
    import pybullet
    import pybullet_data

    client.resetSimulation()
    client.setGravity(0, 0, -9.81)
    plane = client.loadURDF(str(pybullet_data.getDataPath()) + "/plane.urdf")
    body = client.loadURDF(str(robot.path), flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
    lows = [client.getAABB(body, i)[0][2] for i in range(-1, client.getNumJoints(body))]
    pos, orn = client.getBasePositionAndOrientation(body)
    client.resetBasePositionAndOrientation(body, (pos[0], pos[1], pos[2] - min(lows) + 0.005), orn)
    for _ in range(int(STAND_TIME * 240)):
        client.stepSimulation()
    _, orn = client.getBasePositionAndOrientation(body)
    z_axis = client.getMatrixFromQuaternion(orn)[2::3]
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, z_axis[2]))))
    root = robot.roots()[0]
    on_ground = bool(client.getContactPoints(body, plane, linkIndexA=-1))
    if tilt > MAX_TILT_DEG or (on_ground and tilt > MIN_TIP_DEG):
        return [Problem("stability", f"link {root!r}", f"the robot tips over when it stands still: tilted "
                        f"{tilt:.0f} degrees{' onto its chassis' if on_ground else ''} after {STAND_TIME:g} s on "
                        "flat ground", "put the centre of mass (inertial origin) between the wheels and the caster, "
                        "or add a caster under the heavy end")]
    if on_ground:
        return [Problem("stability", f"link {root!r}", "the chassis rests on the ground, not on the wheels",
                        "make the wheels reach below the chassis (a larger wheel radius, or lower wheel joints)")]
    return []
