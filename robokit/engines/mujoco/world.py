"""The mujoco engine: :class:`MujocoWorld`, the World on one MuJoCo model. Its bodies (building, compiling, poses)
are :class:`~robokit.engines.mujoco.bodies.MujocoBodies`; here are the devices: stepping with forces, joint motors
and wrenches, rays, attachments, kinematics, cameras, contacts and episodes.

The state after :meth:`MujocoWorld.step` is consistent: ``mj_step2`` integrates, then ``mj_step1`` computes the
positions and velocities of the new state, so poses read between two steps are those of the current state, and
forces and motor commands set then act during the next step. ``mj_step1`` (and the copy of the solved contacts it
would overwrite) runs when something first looks at the model or data; when nothing does before the next step, that
step runs it, on the same state (a gym env's ticks between two actions read nothing).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from itertools import repeat
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.engines.interface import (
    ChainFrame,
    ChainJoint,
    Clash,
    Contact,
    JointState,
    MotorMode,
    Pose,
    RayCaster,
    RenderedImage,
)
from robokit.engines.mujoco import attach as attachments
from robokit.engines.mujoco import clash, kin, support
from robokit.engines.mujoco import render as rendering
from robokit.engines.mujoco.bodies import MujocoBodies
from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.links import Motors, critical_damping, motor_gains
from robokit.engines.mujoco.rays import HIDDEN_GROUP, MujocoRayCaster
from robokit.errors import UserError

PYRAMIDAL = int(mujoco.mjtCone.mjCONE_PYRAMIDAL)
RAMP_LAG = 6.0
"""Steps of a capped motor's setpoint a joint may lag behind before it counts as held back (a free joint tracks
the moving setpoint about 4 steps behind: critically damped, ``omega * time_step = 0.5``)."""

if TYPE_CHECKING:  # read by attribute only
    from robokit.config import Config


@dataclass(slots=True)
class Ramp:
    """A position motor capped at a velocity, until its setpoint reaches the target (:meth:`MujocoWorld._ramp`)."""

    gains: tuple[float, float, float, float]
    at: float
    """The setpoint now."""
    target: float
    step: float
    """The largest move of the setpoint a step."""
    body: int
    joint: int
    qpos: int = 0
    """The joint's qpos address and the motor's actuator id (until the next compile)."""
    actuator: int = 0


@dataclass(slots=True)
class MotorGroup:
    """The motors one :meth:`MujocoWorld.set_joint_motors` call drives (the same joints, mode and forces as
    before): their actuator names, gains, which are off (force 0), actuator ids, and the motors'
    :attr:`~robokit.engines.mujoco.links.Motors.version` when they were last written."""

    names: list[str]
    gains: list[tuple[float, float, float, float]]
    off: list[bool]
    ids: slice | list[int]
    version: int


class MujocoWorld(MujocoBodies):
    """The World on MuJoCo. Takes the World's keyword arguments; ``gui`` is refused (robokit runs MuJoCo headless).
    """

    engine = "mujoco"
    engine_version = str(mujoco.__version__)

    @classmethod
    def check_config(cls, config: Config, *, gui: bool | None = None) -> None:
        """Refuse what MuJoCo cannot build (SDF bodies, a GUI window): see :mod:`robokit.engines.mujoco.support`."""
        support.check_config(config, gui=gui)

    def __init__(self, *, gui: bool = False, time_step: float = 1.0 / 240.0,
                 gravity: Sequence[float] = (0.0, 0.0, -9.81), solver_iterations: int = 50, seed: int = 0,
                 base_dir: str | Path = ".", engine: str | None = None) -> None:
        super().__init__(gui=gui, time_step=time_step, gravity=gravity, solver_iterations=solver_iterations,
                         seed=seed, base_dir=base_dir, engine=engine)
        self._forces: list[tuple[int, np.ndarray, np.ndarray]] = []
        self.motors = Motors()
        self.joins = attachments.Joins()
        self.cameras = rendering.Cameras()
        self._wrenches: dict[tuple[int, int], tuple[tuple[float, ...], tuple[float, ...]]] = {}
        """(body, joint) -> reaction wrench of the last step (child frame) and that frame's rotation."""
        self._addresses: dict[tuple[int | str, int], tuple[int, int, int]] = {}
        """(body, joint) -> MuJoCo joint id, qpos and dof address (until the next compile)."""
        self._drives: dict[tuple[Any, ...], tuple[str, tuple[float, float, float, float]]] = {}
        """(body, joint, mode, force) -> actuator name and its (gain, position bias, velocity bias, force limit)."""
        self._groups: dict[tuple[Any, ...], MotorGroup] = {}
        """(body, joints, mode, forces) -> the motors :meth:`set_joint_motors` drives (until the next compile)."""
        self._rows: dict[tuple[Any, ...], tuple[np.ndarray | slice, np.ndarray | slice, list[bool]]] = {}
        """(body, joints) -> their qpos and dof addresses and which move, for :meth:`joint_states`."""
        self._chains: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, int]] = {}
        """(body, link) -> its movable joints' qpos and dof addresses and the link's MuJoCo body (until the next
        compile), for :meth:`jacobian`."""
        self._ik_rows: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]] = {}
        """(body, link) -> what the IK looks up (:func:`~robokit.engines.mujoco.kin.ik_rows`), until the next
        compile."""
        self._scratch: tuple[Any, Any] | None = None
        """(model, an MjData of it) for kinematics computed off the world's state."""
        self._solved: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        """The contacts the last step solved: their geom pairs, points, normals and normal forces (None: not worked
        out yet from :attr:`_kept`, or none)."""
        self._pyramidal = False
        """The compiled model's friction cones are pyramids (robokit's own scenes have elliptic ones)."""
        self._kept: tuple[Any, ...] | None = None
        """Copies of the last step's contact arrays and constraint forces, for :meth:`_solved_contacts`."""
        self._geom_owner: list[tuple[int, int]] | None = None
        """Per MuJoCo geom: (robokit body id, link) of its body, (-1, -1) for none (until the next compile)."""
        self._ramps: dict[str, Ramp] = {}
        """Position motors capped at a velocity, by actuator name, until the setpoint reaches the target
        (:meth:`_ramp`)."""
        self._applied: Any = None
        """The holding forces ``qfrc_applied`` still holds from the last step (nothing else is in it), or None: it
        is zero."""

    def step(self) -> None:
        """Advance physics by one step (forces applied since the last step act during it)."""
        if self._dirty:
            self._compile()
        m, d, motors, grips = self._model, self._data, self.motors, self.scene.grips
        if self._unsettled:  # nothing looked at the state since it changed: its positions stage runs now, on it
            self._unsettled = self._stepped = False
            mujoco.mj_step1(m, d)
            if grips.pending:
                grips.after_positions(m, d)
            motors.inertia_changed = False  # that stage computed the mass matrix with the new armature
        elif motors.inertia_changed:  # the mass matrix mj_step1 computed predates a new armature
            mujoco.mj_step1(m, d)
            motors.inertia_changed = False
        if self._ramps:
            self._advance_ramps(m, d)
        hold = motors.holding(m, d)  # a position motor carries its links' weight, as PyBullet's motor its target
        if self._forces or hold is not self._applied:  # applied forces start from zero
            if self._applied is not None:
                d.qfrc_applied[:] = 0.0
                self._applied = None
            for bid, force, point in self._forces:
                mujoco.mj_applyFT(m, d, force, np.zeros(3), point, bid, d.qfrc_applied)
            if hold is not None:
                hold.add(d)
        elif hold is not None:  # only the holding forces, on the joints of the last step's: written over
            hold.put(d)
        if grips.held:
            self._step_holding(m, d)
        else:
            mujoco.mj_step2(m, d)
        if grips.fingers:
            grips.take_up(m, d)
        if self._wrenches:
            self._measure_wrenches(m, d)
        if motors.torques:
            motors.after_step(m, d)
        if self._forces:
            d.qfrc_applied[:] = 0.0
            self._forces.clear()
        else:
            self._applied = hold
        self._solved = self._kept = None
        self._unsettled = self._stepped = True  # mj_step1 runs when something looks, or at the next step (_settle)
        self.tick += 1
        if self.window is not None:  # the viewer looks at the state: its positions stage runs now, as for any look
            self._settle()
            self.window.sync()

    def _settle(self) -> None:
        """The last step's positions stage, its solved contacts kept first (:meth:`_keep_contacts`), and the grip
        anchors taken up in it welded where they are now."""
        m, d = self._model, self._data
        if self._stepped:
            self._keep_contacts(m, d)
        self._unsettled = self._stepped = False
        mujoco.mj_step1(m, d)
        if self.scene.grips.pending:
            self.scene.grips.after_positions(m, d)

    def _keep_contacts(self, m: Any, d: Any) -> None:
        """Keep the contacts the last step solved, with their forces, before ``mj_step1`` finds the next state's: the
        constraint forces MuJoCo holds after ``mj_step1`` are not yet solved for the contacts it holds then (a new
        contact read memory left from before; a contact list that changed length read its neighbours' forces).
        Only copies here: the forces are worked out when contacts are read (:meth:`_solved_contacts`)."""
        self._solved = None
        if d.ncon == 0:
            self._kept = None
            return
        c = d.contact
        self._kept = (c.geom.copy(), c.pos.copy(), c.frame.copy(), c.efc_address.copy(),
                      c.dim.copy() if self._pyramidal else None, d.efc_force[:d.nefc].copy())

    def _solved_contacts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """The kept contacts of the last step: geom pairs, points, normals and normal forces (None: none)."""
        if self._solved is None and self._kept is not None:
            geoms, points, frames, adr, dim, efc_force = self._kept
            if dim is not None:  # a pyramidal cone: the normal force is the sum of its edges
                rows = np.where(dim == 1, 1, 2 * (dim - 1))
                summed = np.concatenate(([0.0], np.cumsum(efc_force)))
                start = np.maximum(adr, 0)
                force = np.where(adr >= 0, summed[np.minimum(start + rows, len(efc_force))] - summed[start], 0.0)
            else:  # an elliptic cone's first row is the normal force (robokit's scenes: see scene.Scene.new)
                force = efc_force[np.maximum(adr, 0)] if len(efc_force) else np.zeros(len(adr))
                force[adr < 0] = 0.0
            self._solved = (geoms, points, frames[:, :3], force)
        return self._solved

    def _step_holding(self, m: Any, d: Any) -> None:
        """``mj_step2`` (robokit's models have no MuJoCo sensors) with the grip welds judged between the solve and
        the integration: a weld let go is solved again without (:mod:`robokit.engines.mujoco.grip`)."""
        mujoco.mj_fwdActuation(m, d)
        mujoco.mj_fwdAcceleration(m, d)
        mujoco.mj_fwdConstraint(m, d)
        if self.scene.grips.let_go(m, d):
            mujoco.mj_forward(m, d)
        d.qacc_warmstart[:] = d.qacc
        mujoco.mj_Euler(m, d)

    def _after_compile(self, model: Any) -> None:
        """Motor settings live in the model: put them back into a freshly compiled one. MuJoCo's ids changed: drop
        what was looked up by them."""
        self._addresses.clear()
        self._chains.clear()
        self._ik_rows.clear()
        self._drives.clear()
        self._groups.clear()
        self._rows.clear()
        self._geom_owner = None
        self._solved = self._kept = None
        self._pyramidal = model.opt.cone == PYRAMIDAL
        self.motors.reapply(model, self.data, {model.actuator(i).name for i in range(model.nu)})
        for name, ramp in list(self._ramps.items()):
            if name in self.motors.settings:
                self._address_ramp(name, ramp)
            else:  # its body was removed
                del self._ramps[name]

    def remove_body(self, name: str) -> None:
        """Remove a body (the scene is recompiled; the other bodies keep their state)."""
        rid = self.body(name)
        self.compiled()
        for attachment in [a for a, (p, c, _) in self.joins.held.items() if rid in (p, c)]:
            self.detach(attachment)
        self.mounts = {c: p for c, p in self.mounts.items() if rid not in (c, p)}
        self._wrenches = {key: value for key, value in self._wrenches.items() if key[0] != rid}  # measured per step
        root = self._root.pop(rid)
        body = self.scene.spec.body(root)
        for geom in self.scene.geoms_of(body):
            self.scene.contacts.pop(geom.name, None)
        for actuator in list(self.scene.spec.actuators):
            if actuator.name.startswith(f"{name}/"):
                self.scene.spec.delete(actuator)
        self.scene.grips.remove(self.scene.spec, f"{name}/")
        self.scene.spec.delete(body)
        self._static.discard(root)
        self.scene.damping.pop(root, None)
        self._links.pop(rid)
        self._tables.pop(rid, None)
        self._unregister(name)
        self._dirty = True

    def apply_force(self, body: str | int, force: Sequence[float], *, position: Sequence[float] | None = None,
                    link: int = -1) -> None:
        """Apply a force (N, world frame) at a world point (default: the link's origin) in the next step."""
        bid = self._mj(body, link)
        at = np.asarray(position if position is not None else self.data.xpos[bid], dtype=float)
        self._forces.append((bid, np.asarray(force, dtype=float), at))

    # ----------------------------------------------------------------- joints: state and motors
    def _joint(self, body: int | str, joint: int) -> tuple[int, int, int]:
        """MuJoCo joint id, qpos address and dof address of a movable joint."""
        found = self._addresses.get((body, joint))
        if found is not None and not self._dirty:
            return found
        bid = self._mj(body, joint)
        m = self.model
        if m.body_jntnum[bid] == 0:
            raise UserError(f"joint {joint} of {self._label(body)!r} is fixed")
        jid = int(m.body_jntadr[bid])
        found = self._addresses[(body, joint)] = (jid, int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid]))
        return found

    def joint_states(self, body: int, joints: Sequence[int]) -> Sequence[JointState]:
        """Position, velocity, reaction wrench (zeros unless :meth:`enable_joint_wrench`) and last motor force of
        each joint; a fixed joint reads position and velocity 0."""
        m, d = self.compiled()
        key = (body, tuple(joints))
        rows = self._rows.get(key)
        if rows is None:
            rows = self._rows[key] = self._state_rows(body, joints)
        qadr, dadr, movable = rows
        qpos, qvel, torque = d.qpos[qadr].tolist(), d.qvel[dadr].tolist(), d.qfrc_actuator[dadr].tolist()
        zero = (0.0,) * 6
        if not self._wrenches and False not in movable:  # the common read: an arm's joints, no wrench measured
            return list(map(JointState, qpos, qvel, repeat(zero), torque))
        rid = self.body(body) if self._wrenches else -1
        return [JointState(qpos[i] if moves else 0.0, qvel[i] if moves else 0.0,
                           self._wrenches[(rid, j)][0] if (rid, j) in self._wrenches else zero,  # type: ignore[arg-type]
                           torque[i] if moves else 0.0)
                for i, (j, moves) in enumerate(zip(joints, movable, strict=True))]

    def _state_rows(self, body: int, joints: Sequence[int]) -> tuple[np.ndarray | slice, np.ndarray | slice,
                                                                       list[bool]]:
        """qpos and dof addresses of ``joints`` (0 for a fixed one; a slice where they run on one by one, as an
        arm's do) and which of them move (until the next compile)."""
        m = self.model
        movable = [bool(m.body_jntnum[self._mj(body, j)]) for j in joints]
        addresses = [self._joint(body, j)[1:] if moves else (0, 0) for j, moves in zip(joints, movable, strict=True)]

        def rows(values: list[int]) -> np.ndarray | slice:
            if values and values == list(range(values[0], values[0] + len(values))):
                return slice(values[0], values[0] + len(values))
            return np.array(values, dtype=np.int64)

        return rows([a[0] for a in addresses]), rows([a[1] for a in addresses]), movable

    def enable_joint_wrench(self, body: int, joint: int, enabled: bool = True) -> None:
        """Measure (or stop measuring) a joint's reaction wrench at every step."""
        key = (self.body(body), joint)
        if enabled:
            self._mj(body, joint)
            self._wrenches.setdefault(key, ((0.0,) * 6, (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)))
        else:
            self._wrenches.pop(key, None)

    def wrench_frame(self, body: int, joint: int) -> tuple[float, ...]:
        """Rotation (world from child link frame) the joint's reaction was given in, as of the last step."""
        return self._wrenches.get((self.body(body), joint), ((), (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)))[1]

    def _measure_wrenches(self, m: Any, d: Any) -> None:
        """Every measured joint's reaction in the step just taken. The step's pushes (:meth:`apply_force`) went into
        ``qfrc_applied``, which MuJoCo's body-force pass does not see: they are handed to it as the body forces they
        are (``xfrc_applied``, at the centre of mass) while it runs, then taken out again."""
        pushes = [(bid, np.concatenate([force, np.cross(point - d.xipos[bid], force)]))
                  for bid, force, point in self._forces]
        for bid, wrench in pushes:
            d.xfrc_applied[bid] += wrench
        mujoco.mj_rnePostConstraint(m, d)
        for bid, wrench in pushes:
            d.xfrc_applied[bid] -= wrench
        for (rid, joint) in self._wrenches:
            self._wrenches[(rid, joint)] = kin.joint_wrench(m, d, self._mj(rid, joint))

    def reset_joint(self, body: int, joint: int, position: float, velocity: float | None = None) -> None:
        """Set a joint's position and velocity at once (set-up and resets)."""
        _, qadr, dadr = self._joint(body, joint)
        _, d = self._for_writing()
        d.qpos[qadr] = position
        d.qvel[dadr] = velocity or 0.0
        self._positions_written()

    def set_joint_motor(self, body: int, joint: int, mode: MotorMode, *, target_position: float | None = None,
                        target_velocity: float | None = None, force: float | None = None,
                        max_velocity: float | None = None, position_gain: float | None = None) -> None:
        """Drive one joint with its MuJoCo motor; gains come from MuJoCo's model of the joint
        (:func:`~robokit.engines.mujoco.links.motor_gains`), not from PyBullet's."""
        m, d = self.compiled()
        key = (body, joint, mode, force)
        drive = self._drives.get(key)
        if drive is None:
            drive = self._drives[key] = self._drive(body, joint, mode, force)
        name, gains = drive
        if mode == "torque":
            ctrl = float(force or 0.0)
        else:
            ctrl = float((target_velocity if mode == "velocity" else target_position) or 0.0)
        if gains[3] == 0.0 and force is not None:  # force 0: the motor is off (a passive joint)
            ctrl = 0.0
        if mode == "position" and max_velocity is not None and max_velocity > 0.0 and gains[3] != 0.0:
            self._ramp(name, gains, ctrl, max_velocity, body, joint)
            return
        if self._ramps:
            self._ramps.pop(name, None)
        self.motors.set(m, d, name, (*gains, ctrl), torque=mode == "torque")

    def _ramp(self, name: str, gains: tuple[float, float, float, float], target: float, max_velocity: float,
              body: int, joint: int) -> None:
        """A position motor capped at ``max_velocity``: its setpoint moves towards ``target`` by at most
        ``max_velocity * time_step`` a step, from where the motor's setpoint was if it was already a position motor
        and the joint follows it, else from where the joint is. PyBullet caps the velocity its motor asks for, not
        its force: a joint held back (fingers closed on an object, a load beyond the force) is pushed as an uncapped
        motor pushes, so a joint that falls behind its setpoint by more than :data:`RAMP_LAG` steps gets the
        target at once."""
        old = self.motors.settings.get(name)
        qadr = self._joint(body, joint)[1]
        step = max_velocity * self.time_step
        start = at = float(self.data.qpos[qadr])
        ramp = self._ramps.get(name)
        if ramp is not None:
            start = ramp.at
        elif old is not None and old[1] != 0.0 and old[:4] == gains:
            start = old[4]
        if abs(start - at) > RAMP_LAG * step:  # held back (closed on something): from where the joint is
            start = at
        self.motors.set(self._model, self._data, name, (*gains, start), torque=False)
        self._ramps[name] = self._address_ramp(name, Ramp(gains, start, target, step, body, joint))

    def _address_ramp(self, name: str, ramp: Ramp) -> Ramp:
        """Look up the ramp's qpos address and actuator id in the model as compiled now."""
        ramp.qpos = self._joint(ramp.body, ramp.joint)[1]
        ramp.actuator = self.motors.actuator(self._model, name)
        return ramp

    def _advance_ramps(self, m: Any, d: Any) -> None:
        """Move each capped position motor's setpoint one step towards its target (see :meth:`_ramp`): its control
        only, the motor's stored setting once the target is reached (a recompile in between puts back the start)."""
        ctrl, qpos, ramps = d.ctrl, d.qpos, self._ramps
        for name, ramp in list(ramps.items()):
            at, target, step = ramp.at, ramp.target, ramp.step
            ahead = 1.0 if target > at else -1.0
            if abs(target - at) <= step or (at - qpos[ramp.qpos]) * ahead > RAMP_LAG * step:
                del ramps[name]
                self.motors.set(m, d, name, (*ramp.gains, target), torque=False)
                continue
            ramp.at = at = at + ahead * step
            ctrl[ramp.actuator] = at

    def _drive(self, body: int, joint: int, mode: MotorMode, force: float | None) -> tuple[
            str, tuple[float, float, float, float]]:
        """A joint motor's actuator name and gains (gain, position bias, velocity bias, force limit) in ``mode``."""
        jid, _, dadr = self._joint(body, joint)
        m = self.model
        info = self.joints(body)[joint]
        limit = abs(float(force)) if force is not None else info.max_force
        inertia = float(m.dof_M0[dadr])
        kv, kp = motor_gains(limit, inertia, self.time_step)
        if force is not None and limit == 0.0:
            gains = (0.0, 0.0, 0.0, 0.0)
        elif mode == "torque":
            gains = (1.0, 0.0, 0.0, limit)
        elif mode == "velocity":
            gains = (kv, 0.0, -kv, limit if force is not None or limit > 0 else 0.0)
        else:
            gains = (kp, -kp, -critical_damping(kp, inertia), limit)
        return f"{m.joint(jid).name}/motor", gains

    def set_joint_motors(self, body: int, joints: Sequence[int], mode: MotorMode, *,
                         target_positions: Sequence[float] | None = None,
                         target_velocities: Sequence[float] | None = None, forces: Sequence[float] | None = None,
                         position_gains: Sequence[float] | None = None,
                         velocity_gains: Sequence[float] | None = None) -> None:
        """:meth:`set_joint_motor` for many joints (the same, in one loop: an arm sends its targets every tick)."""
        if self._dirty:
            self._compile()
        # controls and gains only: mj_step1 reads neither (an armature is flagged), so the state need not be settled
        m, d, motors, drives = self._model, self._data, self.motors, self._drives
        torque = mode == "torque"
        values = forces if torque else target_velocities if mode == "velocity" else target_positions
        key = (body, tuple(joints), mode, None if forces is None else tuple(forces))
        group = self._groups.get(key)
        if group is not None and group.version == motors.version and motors.torques.isdisjoint(group.names):
            # the same motors with the gains they have: only the controls are new (an arm's targets every tick)
            if self._ramps:
                for name in group.names:
                    self._ramps.pop(name, None)
            controls = [0.0] * len(group.names) if values is None else [
                0.0 if off else float(value or 0.0) for value, off in zip(values, group.off, strict=True)]
            motors.put_controls(d, group.names, group.gains, controls, group.ids)
            return
        for i, joint in enumerate(joints):
            force = None if forces is None else forces[i]
            drive = drives.get((body, joint, mode, force))
            if drive is None:
                drive = drives[(body, joint, mode, force)] = self._drive(body, joint, mode, force)
            name, gains = drive
            if self._ramps:
                self._ramps.pop(name, None)
            value = None if values is None else values[i]
            ctrl = 0.0 if gains[3] == 0.0 and force is not None else float(value or 0.0)
            motors.set(m, d, name, (*gains, ctrl), torque=torque)
        if not torque:
            self._groups[key] = self._motor_group(body, joints, mode, forces)

    def _motor_group(self, body: int, joints: Sequence[int], mode: MotorMode,
                     forces: Sequence[float] | None) -> MotorGroup:
        """The motors of ``joints`` as just set (their ids a slice where they run on one by one, as an arm's do)."""
        drives = [self._drives[(body, joint, mode, None if forces is None else forces[i])]
                  for i, joint in enumerate(joints)]
        names = [name for name, _ in drives]
        ids = [self.motors.actuator(self._model, name) for name in names]
        rows: slice | list[int] = ids
        if ids and ids == list(range(ids[0], ids[0] + len(ids))):
            rows = slice(ids[0], ids[0] + len(ids))
        off = [gains[3] == 0.0 and forces is not None for _, gains in drives]
        return MotorGroup(names, [gains for _, gains in drives], off, rows, self.motors.version)

    # ----------------------------------------------------------------- rays
    def ray_caster(self, *, skip: Collection[int] = (), see_hidden: bool = True, mask: int = -1,
                   num_threads: int = 1, analytic: bool = True) -> RayCaster:
        """A caster on MuJoCo's ``mj_multiRay`` / ``mj_ray`` (``mask``, ``num_threads``, ``analytic`` do not apply)."""
        return MujocoRayCaster(self, skip, see_hidden)

    def hide_from_rays(self, body: int) -> None:
        """Put the body's geoms in the geom group rays of ``see_hidden=False`` casters leave out."""
        for geom in self.scene.geoms_of(self.scene.spec.body(self._root[self.body(body)])):
            geom.group = HIDDEN_GROUP
        self._dirty = True

    # ----------------------------------------------------------------- attachments
    def attach(self, parent: int, parent_link: int, child: int, *, position: Sequence[float] | None = None,
               max_force: float | None = None) -> int:
        """A weld (see :mod:`robokit.engines.mujoco.attach`)."""
        return attachments.attach(self, self.joins, parent, parent_link, child, position=position, max_force=max_force)

    def mount(self, child: str, parent: str, link: int, *, position: Sequence[float] = (0.0, 0.0, 0.0),
              orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0), max_force: float = 10_000.0) -> int:
        """A tool on a flange: a weld, the two bodies out of each other's contacts (MuJoCo's stiffness)."""
        return attachments.mount(self, self.joins, child, parent, link, position, orientation)

    def couple_joints(self, body: int, leader: int, follower: int, ratio: float, *, erp: float,
                      max_force: float) -> int:
        """A joint equality (see :mod:`robokit.engines.mujoco.attach`)."""
        return attachments.couple_joints(self, self.joins, body, leader, follower, ratio, erp=erp, max_force=max_force)

    def detach(self, attachment: int) -> None:
        """Remove an attachment."""
        attachments.detach(self, self.joins, attachment)

    def joined(self, a: int, b: int) -> bool:
        """True if an attachment joins ``a`` and ``b`` directly."""
        return attachments.joined(self, self.joins, a, b)

    def disable_collisions(self, body: int) -> None:
        """Take a body's base out of contact."""
        attachments.disable_collisions(self, body)

    # ----------------------------------------------------------------- kinematics
    def kinematic_chain(self, body: int, link: int) -> list[ChainFrame | ChainJoint]:
        """The frames from the world to a link (see :mod:`robokit.engines.mujoco.kin`)."""
        return kin.kinematic_chain(self, body, link)

    def jacobian(self, body: int, link: int, positions: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo's Jacobian of a link's frame origin (see :mod:`robokit.engines.mujoco.kin`)."""
        m, _ = self.compiled()
        if self._scratch is None or self._scratch[0] is not m:  # an MjData costs ms to make: one per model
            self._scratch = (m, mujoco.MjData(m))
        rows = self._chains.get((body, link))
        if rows is None:
            rows = self._chains[(body, link)] = kin.chain_rows(self, body, link)
        return kin.jacobian(self, rows, positions, self._scratch[1])

    def inverse_kinematics(self, body: int, link: int, position: Sequence[float], orientation: Sequence[float], *,
                           seed: Sequence[float], damping: Sequence[float], iterations: int,
                           tolerance: float) -> list[float] | None:
        """Damped least squares on MuJoCo's Jacobian (see :func:`robokit.engines.mujoco.kin.inverse_kinematics`)."""
        m, _ = self.compiled()
        if self._scratch is None or self._scratch[0] is not m:
            self._scratch = (m, mujoco.MjData(m))
        rows = self._ik_rows.get((body, link))
        if rows is None:
            rows = self._ik_rows[(body, link)] = kin.ik_rows(self, body, link)
        return kin.inverse_kinematics(self, rows, position, orientation, seed, damping, iterations, tolerance,
                                      self._scratch[1])

    def clashes(self, body: int, joints: Sequence[int], positions: Sequence[float], *,
                carried: Sequence[tuple[int, int, Pose]] = (), skip: Collection[int] = (),
                margin: float = 0.0) -> list[Clash]:
        """``mj_geomDistance`` in a scratch ``MjData`` (see :mod:`robokit.engines.mujoco.clash`)."""
        m, _ = self.compiled()
        if self._scratch is None or self._scratch[0] is not m:
            self._scratch = (m, mujoco.MjData(m))
        return clash.clashes(self, self._scratch[1], body, joints, positions, carried=carried, skip=skip,
                             margin=margin)

    # ----------------------------------------------------------------- cameras
    def render(self, width: int, height: int, view: Sequence[float], projection: Sequence[float], *, near: float,
               far: float, segmentation: bool = True, renderer: str = "tiny") -> RenderedImage:
        """One image from MuJoCo's OpenGL renderer (``renderer`` does not apply: there is one)."""
        return rendering.render(self, self.cameras, width, height, view, projection, near=near, far=far,
                                    segmentation=segmentation)

    # ----------------------------------------------------------------- contacts
    def contacts(self, body: int, other: int | None = None, *, link: int | None = None,
                 other_link: int | None = None) -> list[Contact]:
        """Contact points of ``body`` as the last step solved them (as PyBullet reports a step's contacts); the point
        is MuJoCo's (midway between the surfaces), before the step moved the bodies."""
        m, _ = self.compiled()
        rid = self.body(body)
        out: list[Contact] = []
        solved = self._solved_contacts()
        if solved is None:
            return out
        geoms, points, normals, forces = solved
        owner_of = self._geom_owners(m)
        # plain lists: a step's few dozen contacts are cheaper walked in Python than masked in numpy
        for i, (g1, g2) in enumerate(geoms.tolist()):  # in MuJoCo's contact order, geom 1's side first
            first, second = owner_of[g1], owner_of[g2]
            if first[0] != rid and second[0] != rid:
                continue
            for side, ((mine, la), (b, lb)) in enumerate(((first, second), (second, first))):
                if mine != rid or (link is not None and la != link) or (other is not None and b != other) or (
                        other_link is not None and lb != other_link):
                    continue
                sign = -1.0 if side == 0 else 1.0  # MuJoCo's normal points from geom 1 to geom 2
                frame = normals[i].tolist()
                normal = (sign * frame[0], sign * frame[1], sign * frame[2])
                out.append(Contact(b, la, lb, float(forces[i]), tuple(points[i].tolist()), normal))
        return out

    def _geom_owners(self, m: Any) -> list[tuple[int, int]]:
        """Per MuJoCo geom of the compiled model: its (robokit body id, link), (-1, -1) for a geom of no body."""
        if self._geom_owner is None:
            self._geom_owner = [self._owner.get(int(m.geom_bodyid[g]), (-1, -1)) for g in range(m.ngeom)]
        return self._geom_owner

    # ----------------------------------------------------------------- episodes, lifetime
    def snapshot(self) -> dict[str, Any]:
        """The whole state (positions, velocities, motor commands and settings)."""
        m, d = self.compiled()
        return {"qpos": d.qpos.copy(), "qvel": d.qvel.copy(), "ctrl": d.ctrl.copy(), "motors": self.motors.saved(m)}

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Put a :meth:`snapshot` back exactly, warm starts cleared, and the clock to tick 0."""
        m, d = self.compiled()
        mujoco.mj_resetData(m, d)
        self._applied = None
        self._ramps.clear()
        self.motors.put_back(m, snapshot["motors"])  # gains and armatures live in the model: reset keeps them
        d.qpos[:], d.qvel[:], d.ctrl[:] = snapshot["qpos"], snapshot["qvel"], snapshot["ctrl"]
        self.scene.grips.let_go_of_all()  # mj_resetData switched their welds off
        self._positions_written()
        self._solved = self._kept = None
        self.tick = 0

    def close(self) -> None:
        """Close the renderers and the viewer, drop the model and data. Safe to call twice."""
        self.cameras.close()
        if self.window is not None:
            self.window.close()
        self._model = self._data = self.client = None
        self._unsettled = False
