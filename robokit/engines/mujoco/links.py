"""A robot's links and joints on the mujoco engine, numbered as the World interface numbers them.

MuJoCo turns each URDF link into a body and keeps only the joints that move; the World numbers links ``-1`` (the
base) and ``0 .. n-1`` (link ``i`` is the child of joint ``i``, fixed joints included). The joint table therefore
comes from the URDF itself (names of fixed joints, effort and velocity limits), laid over MuJoCo's body order.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robokit.engines.interface import JointInfo

URDF_TYPES = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed",
              "floating": "fixed", "planar": "planar"}


@dataclass(frozen=True)
class UrdfJoint:
    """One ``<joint>`` of a URDF: its name, type, limits (rad or m, N·m or N, rad/s or m/s), dynamics, child."""

    name: str
    type: str
    lower: float
    upper: float
    effort: float
    velocity: float
    damping: float
    friction: float


def _float(element: ET.Element | None, attribute: str, default: float) -> float:
    if element is None or element.get(attribute) is None:
        return default
    try:
        return float(element.get(attribute, default))
    except ValueError:
        return default


def urdf_joints(path: Path) -> dict[str, UrdfJoint]:
    """Child link name -> the URDF joint that moves it."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError:  # MuJoCo's reader is more lenient: its own joints stand in (see joint_table)
        return {}
    out = {}
    for joint in root.iter("joint"):
        child = joint.find("child")
        if child is None or child.get("link") is None:
            continue
        kind = URDF_TYPES.get(joint.get("type", "fixed"), "fixed")
        limit, dynamics = joint.find("limit"), joint.find("dynamics")
        unlimited = joint.get("type") == "continuous"
        out[str(child.get("link"))] = UrdfJoint(
            name=joint.get("name", ""), type=kind,
            lower=0.0 if unlimited else _float(limit, "lower", 0.0),
            upper=-1.0 if unlimited else _float(limit, "upper", -1.0),
            effort=_float(limit, "effort", 0.0), velocity=_float(limit, "velocity", 0.0),
            damping=_float(dynamics, "damping", 0.0), friction=_float(dynamics, "friction", 0.0))
    return out


def joint_table(links: list[str], joints: dict[str, UrdfJoint], mujoco_joints: dict[str, UrdfJoint]) -> list[
        JointInfo]:
    """The World's joint table of a robot whose non-base links are ``links`` (MuJoCo's body order): the URDF's
    joints, else MuJoCo's (``mujoco_joints``, by child link), else a fixed joint named after the link."""
    table = []
    for i, link in enumerate(links):
        fixed = UrdfJoint(f"{link}_joint", "fixed", 0.0, -1.0, 0.0, 0.0, 0.0, 0.0)
        j = joints.get(link) or mujoco_joints.get(link, fixed)
        table.append(JointInfo(index=i, name=j.name, type=j.type, lower=j.lower, upper=j.upper, max_force=j.effort,
                               max_velocity=j.velocity, damping=j.damping, friction=j.friction, child_link=link))
    return table


def motor_gains(max_force: float, inertia: float, time_step: float) -> tuple[float, float]:
    """Velocity gain (N·m·s/rad) and position gain (N·m/rad) of a joint motor, from MuJoCo's model of the joint.

    ``inertia`` is the joint's own (``dof_M0``). The velocity motor's gain is ``4 * inertia / time_step`` (a time
    constant of a quarter step on the joint alone, kept stable by MuJoCo's implicit integration of actuator damping;
    measured on the diffbot's wheels, 10x more makes them spin up wildly once the force limit clips), at most what
    saturates ``max_force`` 0.05 rad/s off the target. The position motor's stiffness keeps
    ``omega * time_step = 0.5`` on the joint's inertia, at most what saturates ``max_force`` 0.01 rad off target.
    """
    force = max_force if max_force > 0 else 1e9
    kv = min(force / 0.05, 4.0 * inertia / time_step)
    omega = 0.5 / time_step
    kp = min(force / 0.01, inertia * omega * omega)
    return kv, kp


def critical_damping(kp: float, inertia: float) -> float:
    """Damping (N·m·s/rad) that makes a position motor of stiffness ``kp`` on ``inertia`` critically damped."""
    return 2.0 * math.sqrt(max(kp * inertia, 0.0))


ARMATURE_SHARE = 0.5
"""A driven joint's armature (reflected rotor inertia), as a share of ``time_step * damping`` of its motor.

MuJoCo's implicit integrators fold a motor's damping into the step's mass matrix after the constraint solver has
sized the contact forces against the matrix without it (MuJoCo issue #3443): the hand then moves otherwise than
its contacts were solved for, and an object held by friction slips (17-22 mm over a Panda's transport). robokit
steps with the Euler integrator instead, where the motor's damping is a force the solver sees; the armature keeps
that explicit damping stable (``time_step * damping / (inertia + armature)`` below 2 along every direction)."""


class Holding:
    """The joints position motors drive and their force limits, for adding the clipped bias forces (gravity,
    Coriolis) of those joints to ``qfrc_applied`` each step: on views of ``data``'s arrays where the joints' dofs
    are consecutive (an arm's are), else by index."""

    def __init__(self, data: Any, dofs: list[int], limits: list[float]) -> None:
        self.upper = np.array(limits)
        self.lower = -self.upper
        self.buffer = np.zeros(len(dofs))
        self.dofs = np.array(dofs, dtype=np.int64)
        consecutive = dofs == list(range(dofs[0], dofs[0] + len(dofs)))
        end = dofs[0] + len(dofs)
        self.bias = data.qfrc_bias[dofs[0]:end] if consecutive else None
        self.applied = data.qfrc_applied[dofs[0]:end] if consecutive else None

    def add(self, data: Any) -> None:
        """``qfrc_applied[dofs] += clip(qfrc_bias[dofs], -limit, limit)`` (np.clip's arithmetic)."""
        buffer = self.buffer
        if self.bias is not None and self.applied is not None:
            np.maximum(self.bias, self.lower, out=buffer)
            np.minimum(buffer, self.upper, out=buffer)
            np.add(self.applied, buffer, out=self.applied)
            return
        np.maximum(data.qfrc_bias[self.dofs], self.lower, out=buffer)
        np.minimum(buffer, self.upper, out=buffer)
        data.qfrc_applied[self.dofs] += buffer

    def put(self, data: Any) -> None:
        """``qfrc_applied[dofs] = clip(qfrc_bias[dofs], -limit, limit)``: where nothing else is applied in the step
        (zero plus a force is that force), over what the last step put there."""
        if self.bias is not None and self.applied is not None:
            np.maximum(self.bias, self.lower, out=self.buffer)
            np.minimum(self.buffer, self.upper, out=self.applied)
            return
        np.maximum(data.qfrc_bias[self.dofs], self.lower, out=self.buffer)
        np.minimum(self.buffer, self.upper, out=self.buffer)
        data.qfrc_applied[self.dofs] = self.buffer


_MOTOR_FIELDS = ("actuator_gainprm", "actuator_biasprm", "actuator_forcelimited", "actuator_forcerange", "dof_armature")
"""The model's arrays :class:`Motors` writes."""


class Motors:
    """The joint motors' settings, kept here and written into the model: a recompile (a body added or removed)
    builds a fresh model, and :meth:`reapply` puts every motor back as it was. A driven joint also gets its
    armature (:data:`ARMATURE_SHARE`)."""

    def __init__(self) -> None:
        self.settings: dict[str, tuple[float, float, float, float, float]] = {}
        """Actuator name -> (gain, position bias, velocity bias, force limit (0: none), control)."""
        self.torques: set[str] = set()
        """Motors in torque mode: their torque lasts one step."""
        self.inertia_changed = False
        self.ids: dict[str, int] = {}
        """Actuator name -> id in the model as compiled now."""
        self._holding: Holding | None = None
        """The position motors' joints and force limits (worked out again when a motor changes)."""
        self._worked_out = False
        self.version = 0
        """Counts the writes of gains into the model (and settings or ids replaced): gains and ids a caller took
        from here are still those in force while it has not changed (:meth:`put_controls`)."""

    def set(self, model: Any, data: Any, name: str, setting: tuple[float, float, float, float, float],
            torque: bool) -> None:
        """Store one motor's setting and write it into ``model`` / ``data`` (only the control when the gains are
        those already written: a servo sent new targets every tick)."""
        old = self.settings.get(name)
        self.settings[name] = setting
        if old is None or old[1:4] != setting[1:4]:
            self._worked_out = False
        if torque:
            self.torques.add(name)
        elif self.torques:
            self.torques.discard(name)
        if old is not None and old[:4] == setting[:4]:
            data.ctrl[self._id(model, name)] = setting[4]
            return
        self._write(model, data, name)

    def put_controls(self, data: Any, names: Sequence[str], gains: Sequence[tuple[float, float, float, float]],
                     controls: list[float], ids: slice | list[int]) -> None:
        """Only new controls for motors whose gains are ``gains`` already and which are not in torque mode (the
        caller knows it from :attr:`version`): what :meth:`set` does for each of them, at once."""
        settings = self.settings
        for name, motor_gains, control in zip(names, gains, controls, strict=True):
            settings[name] = (*motor_gains, control)
        data.ctrl[ids] = controls

    def holding(self, model: Any, data: Any) -> Holding | None:
        """The joints a position motor drives (with a force limit), None when there are none."""
        if not self._worked_out:
            rows = sorted((int(model.jnt_dofadr[model.actuator_trnid[self._id(model, name), 0]]), s[3])
                          for name, s in self.settings.items() if s[1] != 0.0 and s[3] > 0.0)
            self._holding = Holding(data, [r[0] for r in rows], [r[1] for r in rows]) if rows else None
            self._worked_out = True
        return self._holding

    def actuator(self, model: Any, name: str) -> int:
        """The id of actuator ``name`` in ``model`` (looked up once per compile)."""
        return self._id(model, name)

    def _id(self, model: Any, name: str) -> int:
        act = self.ids.get(name)
        if act is None:
            act = self.ids[name] = int(model.actuator(name).id)
        return act

    def _write(self, model: Any, data: Any, name: str) -> None:
        self.version += 1
        gain, kp, kd, limit, ctrl = self.settings[name]
        act = self._id(model, name)
        model.actuator_gainprm[act, :3] = (gain, 0.0, 0.0)
        model.actuator_biasprm[act, :3] = (0.0, kp, kd)
        model.actuator_forcelimited[act] = 1 if limit > 0 else 0
        model.actuator_forcerange[act] = (-limit, limit)
        dof = model.jnt_dofadr[model.actuator_trnid[act, 0]]
        armature = ARMATURE_SHARE * model.opt.timestep * -kd
        if model.dof_armature[dof] != armature:
            model.dof_armature[dof] = armature
            self.inertia_changed = True
        data.ctrl[act] = ctrl

    def saved(self, model: Any) -> dict[str, Any]:
        """Every motor's setting and what they wrote into the model (gains, biases, force ranges, armatures), for
        :meth:`put_back`: a world restored to a snapshot drives its joints as it did when the snapshot was taken."""
        return {"settings": dict(self.settings), "torques": set(self.torques),
                "model": {f: getattr(model, f).copy() for f in _MOTOR_FIELDS}}

    def put_back(self, model: Any, saved: dict[str, Any]) -> None:
        """The motors as :meth:`saved` found them (the data's controls are the caller's to restore)."""
        self.settings, self.torques = dict(saved["settings"]), set(saved["torques"])
        self.version += 1
        for f, value in saved["model"].items():
            if f == "dof_armature" and not np.array_equal(model.dof_armature, value):
                self.inertia_changed = True
            getattr(model, f)[:] = value
        self._worked_out = False

    def reapply(self, model: Any, data: Any, names: Collection[str]) -> None:
        """Write every stored motor that still exists (``names``: the model's actuators) into a new model."""
        self.ids.clear()
        self._worked_out = False
        self.version += 1
        for name in [n for n in self.settings if n not in names]:
            del self.settings[name]
            self.torques.discard(name)
        for name in self.settings:
            self._write(model, data, name)

    def after_step(self, model: Any, data: Any) -> None:
        """Torque commands last one step: zero them."""
        for name in self.torques:
            gain, kp, kd, limit, _ = self.settings[name]
            self.settings[name] = (gain, kp, kd, limit, 0.0)
            data.ctrl[self._id(model, name)] = 0.0
