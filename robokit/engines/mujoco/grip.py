"""Grip anchors on the mujoco engine: what PyBullet's ``friction_anchor`` does for a gripper's fingers.

MuJoCo's friction acts on velocities: in each step the contact forces stop a held object's slip at the fingers as
the fingers were at the start of the step. The arm's joints then turn the fingers along an arc while the object's
free joint carries it along a straight line, so the two part by about ``a * h**2 / 2`` per step (``a`` the hand's
acceleration, ``h`` the time step) and nothing brings them back: 1-2 mm per transport of a Panda. PyBullet's
friction anchor corrects that drift at the level of positions; here a soft weld does:

* each finger (a link given ``friction_anchor``) has one weld equality, inactive until it holds something;
* after each step, an object (a free body, not the robot's own) squeezed by two or more fingers for
  :data:`SETTLE_STEPS` steps in a row is welded to the first of them, where it is now;
* in each step the constraints are solved with the welds on first; a weld whose object the fingers no longer
  squeeze, or whose force together with the fingers' friction forces exceeds what that friction could carry (the
  sum of ``friction * normal force`` over their contacts with the object), is switched off and the step solved
  again without it, so an opening hand never drags what it lets go and an object too heavy for the grip slips as
  friction alone would let it.

The weld's reference is as stiff as the fingers' contacts (a time constant of two steps); it carries the drift, not
the load, which friction still carries (a weld force of 1-3 N against 40-50 N the friction could carry, measured on
a Panda carrying a 0.1 kg cube).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robokit.engines.mujoco.gl import mujoco

SETTLE_STEPS = 12
"""Steps an object must have been squeezed by two fingers in a row before it is welded (the fingers' closing
transient is over: a weld taken earlier holds the object where the closing fingers pushed it for a moment)."""


class GripAnchors:
    """The anchors of one world's fingers (see the module's docstring)."""

    def __init__(self) -> None:
        self.fingers: list[str] = []
        """MuJoCo body names of the fingers, in the order their welds were added."""
        self._eq: np.ndarray = np.zeros(0, dtype=np.int64)
        self._grip_of_geom: np.ndarray = np.zeros(0, dtype=np.int64)
        self._grip_geoms: frozenset[int] = frozenset()
        """The fingers' geoms."""
        self._movable: np.ndarray = np.zeros(0, dtype=bool)
        self._root_of_finger: list[int] = []
        self._lists: tuple[list[int], list[int], list[bool], list[int]] = ([], [], [], [])
        """Per geom its finger index (-1: none) and body; per body whether it can be carried, and its root."""
        self.held: dict[int, int] = {}
        """Finger index -> MuJoCo body id of the object its weld holds."""
        self.pending: list[int] = []
        """Fingers whose weld was switched on in this step: their pose is taken after the step."""
        self._touched: dict[tuple[int, int], tuple[float, float, float]] | None = None
        """The contacts :meth:`let_go` found in this step (None: none looked at, or solved again since)."""
        self._squeezed: dict[int, int] = {}
        """Object body id -> for how many steps in a row two or more fingers have squeezed it."""

    @staticmethod
    def weld_name(finger: str) -> str:
        return f"grip/{finger}"

    def add(self, spec: Any, finger: str) -> None:
        """Give the finger body ``finger`` its (inactive) weld."""
        if finger in self.fingers:
            return
        weld = spec.add_equality(name=self.weld_name(finger), type=mujoco.mjtEq.mjEQ_WELD,
                                 objtype=mujoco.mjtObj.mjOBJ_BODY, name1=finger, name2="world")
        weld.active = False
        weld.solref = [2.0 * spec.option.timestep, 1.0]  # as stiff as the fingers' contacts (scene.set_grip)
        self.fingers.append(finger)

    def remove(self, spec: Any, prefix: str) -> None:
        """Drop the welds of fingers whose body names start with ``prefix`` (their robot is removed)."""
        for finger in [f for f in self.fingers if f.startswith(prefix)]:
            spec.delete(spec.equality(self.weld_name(finger)))
            self.fingers.remove(finger)

    def let_go_of_all(self) -> None:
        """Forget every hold (the data's welds were switched off: ``mj_resetData``)."""
        self.held.clear()
        self.pending.clear()
        self._squeezed.clear()
        self._touched = None

    def holds(self, m: Any) -> list[tuple[str, str, np.ndarray]]:
        """Every hold as (finger body name, object body name, its weld's data), to take across a recompile."""
        return [(self.fingers[k], m.body(obj).name, m.eq_data[int(self._eq[k])].copy()) for k, obj in self.held.items()]

    def hold_again(self, m: Any, d: Any, holds: list[tuple[str, str, np.ndarray]]) -> None:
        """After :meth:`compiled`: switch the welds of :meth:`holds` on again, each object where it was held in its
        finger's frame (a hold whose finger or object is gone is dropped)."""
        for finger, obj, data in holds:
            if finger not in self.fingers or mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, obj) < 0:
                continue
            k = self.fingers.index(finger)
            eq = int(self._eq[k])
            m.eq_obj2id[eq] = m.body(obj).id
            m.eq_data[eq] = data
            d.eq_active[eq] = 1
            self.held[k] = int(m.eq_obj2id[eq])

    def compiled(self, m: Any) -> None:
        """Look the fingers, their welds and the free bodies up in a freshly compiled model (every weld is off)."""
        self.let_go_of_all()
        self._eq = np.array([m.equality(self.weld_name(f)).id for f in self.fingers], dtype=np.int64)
        finger_bodies = np.array([m.body(f).id for f in self.fingers], dtype=np.int64)
        grip_of_body = np.full(m.nbody, -1, dtype=np.int64)
        grip_of_body[finger_bodies] = np.arange(len(self.fingers))
        self._grip_of_geom = grip_of_body[m.geom_bodyid]
        self._grip_geoms = frozenset(np.flatnonzero(self._grip_of_geom >= 0).tolist())
        roots = m.body_rootid
        free = np.zeros(m.nbody, dtype=bool)
        for body in range(1, m.nbody):
            jnt = m.body_jntadr[body]
            free[body] = bool(m.body_jntnum[body]) and m.jnt_type[jnt] == mujoco.mjtJoint.mjJNT_FREE
        self._movable = free[roots]  # a body hangs from a free root: it can be carried
        self._root_of_finger = roots[finger_bodies].tolist()
        self._lists = (self._grip_of_geom.tolist(), m.geom_bodyid.tolist(), self._movable.tolist(), roots.tolist())

    def let_go(self, m: Any, d: Any) -> bool:
        """After a constraint solve with welds on: switch off each weld whose object the fingers no longer squeeze
        or whose force exceeds the fingers' friction (the caller solves again without it). True if any."""
        touching = self._touched = self._touching(m, d)
        released = False
        for k, obj in list(self.held.items()):
            fingers, capacity, carried = set(), 0.0, 0.0
            for (finger, body), (_, can_carry, carrying) in touching.items():
                if body == obj:
                    fingers.add(finger)
                    capacity += can_carry
                    carried += carrying
            force = carried + self._weld_force(d, int(self._eq[k]))
            if k not in fingers or len(fingers) < 2 or force > capacity:
                d.eq_active[self._eq[k]] = 0
                del self.held[k]
                released = True
        if released:
            self._touched = None  # solved again: the contacts' forces changed
        return released

    def take_up(self, m: Any, d: Any) -> None:
        """After the step's solve: count how long each object has been squeezed; weld those squeezed long enough
        (their pose is taken by :meth:`after_positions`)."""
        touching = self._touched if self._touched is not None else self._touching(m, d)
        self._touched = None
        if not touching and not self._squeezed:
            return
        squeezed: dict[int, list[int]] = {}
        for finger, body in sorted(touching):
            squeezed.setdefault(body, []).append(finger)
        self._squeezed = {body: self._squeezed.get(body, 0) + 1 for body, fingers in squeezed.items()
                          if len(fingers) >= 2}
        held_objects = set(self.held.values())
        for body, count in self._squeezed.items():
            first = squeezed[body][0]
            if count >= SETTLE_STEPS and body not in held_objects and first not in self.held:
                self.held[first] = body
                self.pending.append(first)

    def after_positions(self, m: Any, d: Any) -> None:
        """After ``mj_step1``: weld each newly held object where it is now in its finger's frame."""
        for k in self.pending:
            eq, finger, obj = int(self._eq[k]), int(m.eq_obj1id[self._eq[k]]), self.held[k]
            rel_pos, rel_quat = np.zeros(3), np.zeros(4)
            inverse_pos, inverse_quat = np.zeros(3), np.zeros(4)
            mujoco.mju_negPose(inverse_pos, inverse_quat, d.xpos[finger], d.xquat[finger])
            mujoco.mju_mulPose(rel_pos, rel_quat, inverse_pos, inverse_quat, d.xpos[obj], d.xquat[obj])
            m.eq_obj2id[eq] = obj
            m.eq_data[eq, :11] = [0.0, 0.0, 0.0, *rel_pos, *rel_quat, 1.0]
            d.eq_active[eq] = 1
        self.pending.clear()

    def _touching(self, m: Any, d: Any) -> dict[tuple[int, int], tuple[float, float, float]]:
        """(finger index, object body id) -> (normal force, friction capacity, friction force) of their contacts in
        this step (N; the capacity is ``friction * normal force``, the friction force the tangential part)."""
        out: dict[tuple[int, int], tuple[float, float, float]] = {}
        if d.ncon == 0:
            return out
        contact = d.contact
        geoms = contact.geom.ravel().tolist()  # the geom pairs, one after another
        if self._grip_geoms.isdisjoint(geoms):  # the common step: no finger touches anything
            return out
        # plain lists: a step's few dozen contacts are cheaper walked in Python than picked out in numpy
        grip_of, body_of, movable, roots = self._lists
        addresses, friction, dims, force = contact.efc_address.tolist(), contact.friction, contact.dim, d.efc_force
        for row, at in enumerate(addresses):
            pair = geoms[2 * row], geoms[2 * row + 1]
            if grip_of[pair[0]] < 0 and grip_of[pair[1]] < 0:
                continue
            normal = float(force[at]) if at >= 0 else 0.0
            if normal <= 0.0:
                continue
            mu = float(friction[row, 0])
            tangential = math.hypot(float(force[at + 1]), float(force[at + 2])) if dims[row] > 1 else 0.0
            for side in (0, 1):
                k, other = grip_of[pair[side]], body_of[pair[1 - side]]
                if k < 0 or not movable[other] or roots[other] == self._root_of_finger[k]:
                    continue
                old = out.get((k, other), (0.0, 0.0, 0.0))
                out[(k, other)] = (old[0] + normal, old[1] + mu * normal, old[2] + tangential)
        return out

    @staticmethod
    def _weld_force(d: Any, eq: int) -> float:
        """The size of the translational force (N) weld ``eq`` applied in this step (0 if it was not in it: a weld
        switched on after this step's constraints were made). MuJoCo puts the active equalities' rows first; a
        weld's first three are its translation."""
        ids = d.efc_id[:d.ne].tolist()
        if eq not in ids:
            return 0.0
        row, force = ids.index(eq), d.efc_force
        return math.hypot(float(force[row]), float(force[row + 1]), float(force[row + 2]))
