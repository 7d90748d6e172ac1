"""``ee_delta`` actuator: move an arm's end-effector link by small Cartesian steps (what a learned policy outputs).

A :class:`EEDelta` ``(dx, dy, dz)`` in metres (world frame) asks the end-effector link to move that far from where it
is now, keeping the tool pointing down. The step is turned into joint targets by **one** damped least-squares
solve on the arm's Jacobian (resolved-rate IK: exact to first order for the small steps a controller sends each
control period), with a null-space pull towards the rest pose and the joint limits enforced; the targets go to
PyBullet's position motors once, when the command arrives. That costs one Jacobian and a 6×7 solve per command
(tens of microseconds), against ``ik_arm``'s full path planning, which is for scripted moves.

Targets below ``min_height`` (m, world z) are lifted to it (the table). The reading is an :class:`EEState`:
end-effector position and linear velocity (m, m/s, world frame), orientation, and the arm's joint positions.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from pydantic import Field
from robokit_plugins.kinematics import arm_joints

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.msgs.arm import Quat, down_quaternion, quat_multiply
from robokit.msgs.control import EEDelta, EEState


def _tilt(current: Quat, target: Quat) -> np.ndarray:
    """Small-angle rotation vector (rad, world frame) from ``current`` to ``target``: twice the vector part of
    ``target * conj(current)``, taken the short way round."""
    x, y, z, w = quat_multiply(target, (-current[0], -current[1], -current[2], current[3]))
    return np.array([x, y, z]) * (2.0 if w >= 0 else -2.0)


class EEDeltaConfig(Schema):
    """``[actuators.NAME]`` with ``type = "ee_delta"``."""

    body: str = Field(description="the robot's body name")
    ee_link: str = Field(description="end-effector link, e.g. panda_grasptarget")
    ready_pose: dict[str, float] = Field(default_factory=dict, description="joint name -> start position, rad")
    yaw: float = Field(0.0, description="tool yaw held while moving, rad")
    max_step: float = Field(0.1, gt=0, description="longest step accepted per command, m")
    min_height: float = Field(0.0, description="lowest target z, m")
    max_force: float | None = Field(None, gt=0, description="N·m per joint; default the URDF's")
    damping: float = Field(1e-3, gt=0, description="damped least squares lambda^2")
    null_gain: float = Field(0.1, ge=0, description="pull towards the rest pose per command")


class EEDeltaArm(Actuator):
    """Moves an end-effector link by small Cartesian steps (one Jacobian solve per command)."""

    reading_type = EEState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "panda", "ee_link": "panda_grasptarget",
                   "ready_pose": {"panda_joint4": -2.2, "panda_joint6": 2.0, "panda_joint7": 0.785}},
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "commands": [(0, EEDelta((0.02, 0.0, -0.02))), (30, EEDelta((0.0, 0.03, 0.0)))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: EEDeltaConfig = self.config
        w = self.world
        joints = arm_joints(ctx, cfg.body, cfg.ee_link)
        self.body, self.ee, self.movable, self.arm = joints
        for name in cfg.ready_pose:
            joints.column(name, f"ready_pose.{name}")
        self.cols = joints.columns
        self.arm_index = [j.index for j in self.arm]
        self.lower = np.array([j.lower if j.upper > j.lower else -np.pi for j in self.arm])
        self.upper = np.array([j.upper if j.upper > j.lower else np.pi for j in self.arm])
        states = w.joint_states(self.body, [j.index for j in self.movable])
        self.ready = [cfg.ready_pose.get(j.name, s[0]) for j, s in zip(self.movable, states, strict=True)]
        self.rest = np.array(self.ready)[self.cols]
        self.forces = joints.forces(cfg.max_force)
        self.down = down_quaternion(cfg.yaw)
        self.damping, self.eye = cfg.damping * np.eye(6), np.eye(len(self.cols))
        self.reset()

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Put the arm in its ready pose, at rest, with the motors holding it there."""
        for j, q in zip(self.movable, self.ready, strict=True):
            self.world.reset_joint(self.body, j.index, q, 0.0)
        self.targets = self.rest.copy()
        self.dirty = True

    def command(self, cmd: Any) -> None:
        """Accept an :class:`EEDelta`: solve joint targets for the step now."""
        if not isinstance(cmd, EEDelta):
            raise ValueError(f"ee_delta takes EEDelta((dx, dy, dz)), got {cmd!r}")
        delta = np.asarray(cmd.delta, float)
        if delta.shape != (3,) or not all(map(math.isfinite, delta.tolist())):
            raise ValueError(f"EEDelta needs three finite numbers (m), got {cmd.delta!r}")
        norm = math.sqrt(delta @ delta)  # np.linalg.norm's own arithmetic, without its dispatch
        if norm > self.config.max_step:
            delta = delta * (self.config.max_step / norm)
        w = self.world
        q_all = [s[0] for s in w.joint_states(self.body, [j.index for j in self.movable])]
        ee_pos, ee_orn = w.pose(self.body, self.ee)
        pos = np.array(ee_pos)
        goal = pos + delta
        goal[2] = max(goal[2], self.config.min_height)
        err = np.concatenate([goal - pos, _tilt(ee_orn, self.down)])
        jl, ja = w.jacobian(self.body, self.ee, q_all)
        jac = np.concatenate((jl, ja))[:, self.cols]
        pinv = jac.T @ np.linalg.inv(jac @ jac.T + self.damping)
        q = np.asarray(q_all)[self.cols]
        null = (self.eye - pinv @ jac) @ (self.config.null_gain * (self.rest - q))
        # np.clip's arithmetic on seven numbers, without its dispatch (which costs more than the work)
        self.targets = np.minimum(np.maximum(q + pinv @ err + null, self.lower), self.upper)
        self.dirty = True

    def update(self) -> None:
        """Send new joint targets to the position motors (only when a command changed them)."""
        if not self.dirty:
            return
        self.world.set_joint_motors(self.body, self.arm_index, "position", target_positions=self.targets.tolist(),
                                    forces=self.forces)
        self.dirty = False

    def read(self) -> EEState:
        """End-effector position, velocity and orientation; the arm's joint positions."""
        w = self.world
        position, orientation = w.pose(self.body, self.ee)
        velocity = w.link_velocity(self.body, self.ee)[0]
        q = w.joint_states(self.body, self.arm_index)
        return EEState(position=position, velocity=velocity, orientation=orientation,
                       joint_positions={j.name: st[0] for j, st in zip(self.arm, q, strict=True)})


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("ee_delta", EEDeltaArm, EEDeltaConfig)
