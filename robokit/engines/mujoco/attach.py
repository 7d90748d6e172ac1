"""Attachments on the mujoco engine: a weld equality constraint per attachment (MuJoCo's rigid hold between two
bodies), added to the spec and compiled in (the other bodies keep their state), and geoms switched out of contact.

MuJoCo's weld is a soft constraint (its ``solref``/``solimp``): it holds by MuJoCo's own stiffness, not up to a
``max_force`` (which is accepted and not applied).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from robokit.engines.mujoco import spatial as mm
from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.scene import mj_quat

if TYPE_CHECKING:
    from robokit.engines.mujoco.bodies import MujocoBodies


EQ_DATA = 12
"""Length of an equality constraint's data vector in MuJoCo (``mjNEQDATA``)."""


def _padded(values: list[float]) -> list[float]:
    return values + [0.0] * (EQ_DATA - len(values))


class Joins:
    """The attachments of one world: id -> (parent body, child body, MuJoCo equality name)."""

    def __init__(self) -> None:
        self.count = 0
        self.held: dict[int, tuple[int, int, str]] = {}

    def new(self) -> tuple[int, str]:
        """A fresh attachment id and its equality's name."""
        self.count += 1
        return self.count, f"attachment/{self.count}"


def attach(world: MujocoBodies, joins: Joins, parent: int, parent_link: int, child: int, *,
           position: Sequence[float] | None = None, max_force: float | None = None) -> int:
    """Weld ``child``'s base to ``parent``'s ``parent_link``: as they are now, or with the child's centre of
    mass at ``position`` (m) in the parent link's centre-of-mass frame, orientations aligned."""
    parent_pose = world.pose(parent, parent_link)
    if position is None:
        child_pose = world.pose(child)
    else:
        com_pos, com_orn = world.com_pose(parent, parent_link)
        held = mm.multiply(com_pos, com_orn, position, (0.0, 0.0, 0.0, 1.0))
        offset = world.link_offset(child)
        child_pose = held if offset is None else mm.multiply(*held, *offset)
    rel_pos, rel_orn = mm.multiply(*mm.invert(*parent_pose), *child_pose)
    return weld(world, joins, parent, parent_link, child, rel_pos, rel_orn)


def weld(world: MujocoBodies, joins: Joins, parent: int, parent_link: int, child: int, rel_pos: Sequence[float],
         rel_orn: Sequence[float]) -> int:
    """A weld holding ``child``'s base link frame at ``rel_pos`` / ``rel_orn`` in ``parent_link``'s link frame."""
    names = (world.link_body_name(parent, parent_link), world.link_body_name(child, -1))
    attachment, name = joins.new()
    world.scene.spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_WELD, objtype=mujoco.mjtObj.mjOBJ_BODY,
                                 name1=names[0], name2=names[1],
                                 data=_padded([0.0, 0.0, 0.0, *rel_pos, *mj_quat(rel_orn), 1.0]))
    joins.held[attachment] = (world.body(parent), world.body(child), name)
    world.changed()
    return attachment


def couple_joints(world: MujocoBodies, joins: Joins, body: int, leader: int, follower: int, ratio: float, *, erp: float,
                  max_force: float) -> int:
    """A joint equality: ``follower = ratio * leader`` (MuJoCo's own stiffness; ``erp`` and ``max_force`` are
    PyBullet's and not applied)."""
    m, _ = world.compiled()
    names = [m.joint(int(m.body_jntadr[world.mj_body(body, j)])).name for j in (follower, leader)]
    attachment, name = joins.new()
    world.scene.spec.add_equality(name=name, type=mujoco.mjtEq.mjEQ_JOINT, objtype=mujoco.mjtObj.mjOBJ_JOINT,
                                 name1=names[0], name2=names[1], data=_padded([0.0, ratio]))
    joins.held[attachment] = (world.body(body), world.body(body), name)
    world.changed()
    return attachment


def detach(world: MujocoBodies, joins: Joins, attachment: int) -> None:
    """Remove an attachment (recompiled at the next look; nothing else changes)."""
    join = joins.held.pop(attachment, None)
    if join is None or world.client is None:
        return
    world.scene.spec.delete(world.scene.spec.equality(join[2]))
    world.changed()


def joined(world: MujocoBodies, joins: Joins, a: int, b: int) -> bool:
    """True if an attachment joins ``a`` and ``b`` directly."""
    return any({p, c} == {a, b} for p, c, _ in joins.held.values())


def disable_collisions(world: MujocoBodies, body: int) -> None:
    """Take every link of a body out of contact (and out of restitution pairs)."""
    root = world.scene.spec.body(world.link_body_name(body, -1))
    for geom in world.scene.geoms_of(root):
        geom.contype = geom.conaffinity = 0
        world.scene.contacts.pop(geom.name, None)
    world.changed()


def mount(world: MujocoBodies, joins: Joins, child: str, parent: str, link: int, position: Sequence[float],
          orientation: Sequence[float]) -> int:
    """Move ``child``'s base to ``position`` / ``orientation`` in ``parent``'s ``link`` frame and weld it there; the
    two never collide."""
    pid, cid = world.body(parent), world.body(child)
    world.set_pose(cid, *mm.multiply(*world.pose(pid, link), position, orientation))
    world.scene.spec.add_exclude(bodyname1=world.link_body_name(pid, link), bodyname2=world.link_body_name(cid, -1))
    world.mounts[cid] = pid
    return weld(world, joins, pid, link, cid, position, orientation)
