"""``ik_arm`` actuator: move an arm's end-effector link to poses along interpolated Cartesian paths.

Any fixed-base arm URDF works; the end-effector link is named in config (Panda: ``panda_grasptarget``). The arm
joints are the movable joints between the base and that link, found from the URDF tree; IK arrays (limits, ranges,
rest poses) are sized to *all* movable joints of the robot (9 on the Panda, fingers included).

How a :class:`~robokit.msgs.arm.MoveTo` is executed:

1. The straight path from the current pose to the target is cut into waypoints (``waypoint_spacing`` metres,
   ``waypoint_angle`` radians). Each waypoint is solved by damped least squares, seeded by the previous waypoint
   nudged towards the rest pose (a null-space pull): first by PyBullet's ``calculateInverseKinematics`` (in C, the
   target given in the base's inertial frame, as that function expects), then checked with the arm's own forward
   kinematics (:mod:`robokit_plugins.kinematics`, numpy). A solution outside the joint limits or above
   ``ik_tolerance`` is solved again in numpy with the analytic Jacobian, joint limits enforced and the null-space
   pull in every iteration. IK runs once per waypoint when the command arrives, not per tick.
2. A waypoint that cannot be solved (outside ``reach`` or residual above tolerance) rejects the whole target: the
   arm does not move and its reading says ``failed`` with the reason.
3. Each tick, joint targets are interpolated between waypoint solutions with a smooth (zero end-velocity) time
   profile whose duration follows from ``speed`` (m/s) and ``angular_speed`` (rad/s).
4. ``reached`` is reported once the path is done and the measured end-effector pose is within ``position_tolerance``
   and ``orientation_tolerance``; ``failed`` if it is not within ``settle_timeout`` after the path ends.

No joint state is ever written to evaluate a candidate: forward kinematics and the Jacobian come from a chain of
constant transforms built once at setup. Joint targets are sent only when they change (every tick along a path,
once when it ends), and the reading is computed only when something reads it.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from pydantic import Field
from robokit_plugins.kinematics import Chain, arm_joints

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import (
    ArmState,
    ContactState,
    FollowJoints,
    HoldArm,
    MoveTo,
    Quat,
    Vec3,
    down_quaternion,
    quat_angle,
    quat_multiply,
)


class IkArmConfig(Schema):
    """``[actuators.NAME]`` with ``type = "ik_arm"``. Lengths in metres, angles in radians, times in sim seconds."""

    body: str = Field(description="the robot's body name")
    ee_link: str = Field(description="end-effector link, e.g. panda_grasptarget")
    ee_offset: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="tool-centre point in the end-effector link's frame, metres (e.g. between "
                                     "the fingertips of a gripper whose model has no such link)")
    ee_rpy_deg: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="tool frame's orientation in the end-effector link's frame (roll, pitch, yaw), "
                                     "degrees: targets and readings are poses of this frame")
    ready_pose: dict[str, float] = Field(default_factory=dict, description="joint name -> start position")
    rest_pose: dict[str, float] = Field(default_factory=dict, description="null-space rest; default ready_pose")
    limits: dict[str, tuple[float, float]] = Field(default_factory=dict, description="override URDF limits")
    speed: float = Field(0.8, gt=0, description="Cartesian speed limit, m/s")
    angular_speed: float = Field(3.0, gt=0, description="rad/s")
    min_duration: float = Field(0.05, ge=0, description="shortest path duration, s")
    position_tolerance: float = Field(0.005, gt=0)
    orientation_tolerance: float = Field(0.05, gt=0)
    ik_tolerance: float = Field(0.0005, gt=0, description="IK residual accepted per waypoint, metres")
    ik_iterations: int = Field(30, ge=1, le=1000)
    reach: float | None = Field(None, gt=0, description="max distance from the base to a target, metres")
    waypoint_spacing: float = Field(0.025, gt=0)
    waypoint_angle: float = Field(0.15, gt=0)
    settle_timeout: float = Field(1.0, gt=0)
    max_force: float | None = Field(None, gt=0, description="N·m per joint; default: the URDF's")
    position_gain: float = Field(0.3, gt=0, le=1)
    velocity_gain: float = Field(1.0, ge=0)
    stop_on: str | None = Field(None, description="a contact sensor: a contact (above stop_force) stops the arm "
                                "where it is, for the rest of the run")
    stop_force: float = Field(0.0, ge=0, description="contact normal force that triggers stop_on, N")


REACH_ROUNDS = 4
"""Extra rounds of ``ik_iterations`` the preflight reach check allows at the target."""


def _rotvec(current: Quat, target: Quat) -> np.ndarray:
    """Rotation vector (world frame, radians) taking ``current`` to ``target``."""
    cx, cy, cz, cw = current
    x, y, z, w = quat_multiply(target, (-cx, -cy, -cz, cw))
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    v = np.array([x, y, z])
    n = float(np.linalg.norm(v))
    return np.zeros(3) if n < 1e-12 else v / n * 2.0 * math.atan2(n, w)


def _angles_between(quats: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Angle (radians, 0..pi) between each ``(x, y, z, w)`` quaternion and the matching 3x3 rotation matrix
    (rows of ``quats``, ``rotations``): the angle of ``R(q) @ R.T``, from both its sine and its cosine so that
    small angles keep their precision."""
    x, y, z, w = quats.T
    target = np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)
    rel = target @ rotations.transpose(0, 2, 1)
    axis = np.stack([rel[:, 2, 1] - rel[:, 1, 2], rel[:, 0, 2] - rel[:, 2, 0], rel[:, 1, 0] - rel[:, 0, 1]], axis=-1)
    return np.arctan2(np.linalg.norm(axis, axis=1), rel[:, 0, 0] + rel[:, 1, 1] + rel[:, 2, 2] - 1.0)


def _where(pos: np.ndarray) -> str:
    """A position for a message, millimetre precision (formatted only when a message needs it)."""
    return f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f})"


def _slerp(a: Quat, b: Quat, s: float) -> Quat:
    """Spherical interpolation from ``a`` (s = 0) to ``b`` (s = 1), the short way round (plain floats: called
    once per waypoint)."""
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    if dot < 0:
        b, dot = (-b[0], -b[1], -b[2], -b[3]), -dot
    if dot > 0.9995:
        q = [x + s * (y - x) for x, y in zip(a, b, strict=True)]
    else:
        th = math.acos(dot)
        wa, wb, sin_th = math.sin((1 - s) * th), math.sin(s * th), math.sin(th)
        q = [(wa * x + wb * y) / sin_th for x, y in zip(a, b, strict=True)]
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


class IkArm(Actuator):
    """Moves an arm's end-effector link along interpolated Cartesian paths (IK per waypoint, not per tick)."""

    reading_type = ArmState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "panda", "ee_link": "panda_grasptarget",
                   "ready_pose": {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8,
                                  "panda_joint7": 0.785}},
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "commands": [(0, MoveTo((0.5, 0.1, 0.3))), (30, MoveTo((0.45, -0.1, 0.25), yaw=0.3))],
    }

    # ------------------------------------------------------------------ setup
    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: IkArmConfig = self.config
        w = self.world
        self._joints = arm_joints(ctx, cfg.body, cfg.ee_link)
        self.body, self.ee, self.movable, self.arm = self._joints
        self._movable_indices = [j.index for j in self.movable]
        self._limits()
        self.ready = self._pose_vector(cfg.ready_pose, "ready_pose", self._measured_all())
        self.rest = self._pose_vector(cfg.rest_pose, "rest_pose", self.ready) if cfg.rest_pose else self.ready
        self.arm_cols = self._joints.columns
        for j, q in zip(self.movable, self.ready, strict=True):
            if j in self.arm or j.name in cfg.ready_pose:
                w.reset_joint(self.body, j.index, float(q))
        self.forces = self._joints.forces(cfg.max_force)
        self.q_cmd = self.ready[self.arm_cols].copy()
        self.path: list[np.ndarray] | None = None
        self.status, self.reason, self.command_id = "idle", "", 0
        self.target: tuple[Vec3, Quat] | None = None
        self.base_pos = np.array(w.pose(self.body)[0])
        tool_orn = w.quaternion_from_euler([math.radians(a) for a in cfg.ee_rpy_deg])
        self._tool = (list(cfg.ee_offset), list(tool_orn))  # the tool frame in the end-effector link's frame
        self._tool_inv = w.invert_transform(*self._tool)
        self._has_tool = any(cfg.ee_offset) or any(cfg.ee_rpy_deg)
        self.chain = Chain(w, self.body, self.ee, {j.index: k for k, j in enumerate(self.movable)}, tool=self._tool)
        self._indices = [j.index for j in self.arm]
        self._names = self._joints.names
        self._ik_options: dict[str, Any] = {"damping": [0.01] * len(self.movable), "iterations": cfg.ik_iterations,
                                            "tolerance": cfg.ik_tolerance / 10.0}
        self._rest_list = self.rest.tolist()
        self._gains = ([cfg.position_gain] * len(self.arm), [cfg.velocity_gain] * len(self.arm))
        self._zero = [0.0] * len(self.arm)
        self._holding = False  # the last target sent was a hold (zero velocity): nothing to resend
        self.stopped, self.latched = False, False
        if cfg.stop_on is not None and getattr(ctx.components.get(cfg.stop_on), "reading_type", None) is not \
                ContactState:
            raise ConfigError(f"{cfg.stop_on!r} is not a contact sensor; components: {', '.join(ctx.components)}",
                              key="stop_on")
        self._apply(self.q_cmd, None)

    def _limits(self) -> None:
        cfg: IkArmConfig = self.config
        for name in cfg.limits:
            self._joints.column(name, "limits")
        lo, hi = [], []
        for j in self.movable:
            low, high = cfg.limits.get(j.name, (j.lower, j.upper))
            if high <= low:  # continuous joint
                low, high = -2 * math.pi, 2 * math.pi
            lo.append(low)
            hi.append(high)
        self.lower, self.upper = np.array(lo), np.array(hi)

    def _pose_vector(self, pose: dict[str, float], key: str, default: np.ndarray) -> np.ndarray:
        out = np.array(default, float)
        for name, value in pose.items():
            out[self._joints.column(name, key)] = value
        return np.clip(out, self.lower, self.upper)

    # ------------------------------------------------------------------ kinematics
    def _measured_all(self) -> np.ndarray:
        states = self.world.joint_states(self.body, self._movable_indices)
        return np.array([s[0] for s in states])

    def _ik(self, q_all: np.ndarray, pos: np.ndarray, orn: Quat) -> np.ndarray:
        """The engine's IK answer for one pose (PyBullet: C, a few tens of microseconds), seeded from ``q_all`` moved a
        little towards the rest pose (a null-space pull). Not checked: see :meth:`_solve` and :meth:`_solve_path`.
        An engine without IK of its own answers ``q_all`` itself (the check then hands the pose to numpy)."""
        # In plain floats (the same arithmetic as numpy's, element by element): one waypoint is a handful of
        # values, where each numpy call would cost more than its work.
        q, rest, cols = q_all.tolist(), self._rest_list, self.arm_cols
        seed = list(q)
        for c in cols:
            seed[c] = q[c] + 0.05 * (rest[c] - q[c])
        w = self.world
        link_pos, link_orn = pos.tolist(), orn
        if self._has_tool:  # the engine solves for the link's frame: the target tool pose times the inverse tool
            link_pos, link_orn = w.multiply_transforms(link_pos, link_orn, *self._tool_inv)
        found = w.inverse_kinematics(self.body, self.ee, link_pos, link_orn, seed=seed, **self._ik_options)
        if found is not None:
            for c in cols:
                q[c] = found[c]
        return np.array(q)

    def _check(self, qs: np.ndarray, poses: list[tuple[np.ndarray, Quat]]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """PyBullet IK answers (rows of ``qs``) against their target poses, in one forward-kinematics pass: per
        answer whether it is taken (joint limits kept, IK tolerance met), and its position and angle residuals."""
        positions, rotations = self.chain.fk_many(qs)
        ep = np.linalg.norm(np.array([pos for pos, _ in poses]) - positions, axis=1)
        eo = _angles_between(np.array([orn for _, orn in poses], float), rotations)
        tol, cols = self.config.ik_tolerance, self.arm_cols
        ok = (np.all(qs[:, cols] >= self.lower[cols], axis=1) & np.all(qs[:, cols] <= self.upper[cols], axis=1)
              & (ep < tol) & (eo < tol * 4))
        return ok, ep, eo

    def _solve_path(self, q_all: np.ndarray, poses: list[tuple[np.ndarray, Quat]]
                    ) -> list[tuple[np.ndarray, float, float]]:
        """Every waypoint of a path, each seeded with the previous solution: (solution, residuals) per pose.

        Exactly what :meth:`_solve` gives waypoint by waypoint, cheaper: PyBullet's answers for the whole path come
        first and are checked with one batched forward-kinematics pass; from the first answer that fails the
        check on, the path is solved waypoint by waypoint (numpy solver where PyBullet's answer fails).
        """
        answers, q = [], q_all
        for pos, orn in poses:
            q = self._ik(q, pos, orn)
            answers.append(q)
        ok, ep, eo = self._check(np.array(answers), poses)
        good = len(poses) if ok.all() else int(np.argmin(ok))  # answers before the first rejected one
        out = [(answers[k], float(ep[k]), float(eo[k])) for k in range(good)]
        q = out[-1][0] if out else q_all
        for pos, orn in poses[len(out):]:
            solved = self._solve(q, pos, orn)
            out.append(solved)
            q = solved[0]
        return out

    def _solve(self, q_all: np.ndarray, pos: np.ndarray, orn: Quat) -> tuple[np.ndarray, float, float]:
        """One waypoint from ``q_all``; returns (solution, position residual m, angle residual rad).

        PyBullet's IK first (:meth:`_ik`); if its answer breaks a joint limit or misses the tolerance, the numpy
        solver below takes over.
        """
        q = self._ik(q_all, pos, orn)
        ok, ep, eo = self._check(q[None], [(pos, orn)])
        if ok[0]:
            return q, float(ep[0]), float(eo[0])
        return self._solve_numpy(q_all, pos, orn)

    def _solve_numpy(self, q_all: np.ndarray, pos: np.ndarray, orn: Quat) -> tuple[np.ndarray, float, float]:
        """Damped least squares on the analytic Jacobian, joint limits enforced, null-space pull to the rest pose."""
        cfg: IkArmConfig = self.config
        q = q_all.copy()
        cols = self.arm_cols
        ep, eo = np.zeros(3), np.zeros(3)
        for _ in range(cfg.ik_iterations):
            jac, cur, corn = self.chain.jacobian(q)
            ep, eo = pos - cur, _rotvec(corn, orn)
            if np.linalg.norm(ep) < cfg.ik_tolerance and np.linalg.norm(eo) < cfg.ik_tolerance * 4:
                break
            err = np.concatenate([ep, eo])
            jjt = jac @ jac.T + 1e-4 * np.eye(6)
            pinv = jac.T @ np.linalg.inv(jjt)
            null = (np.eye(len(cols)) - pinv @ jac) @ (0.05 * (self.rest[cols] - q[cols]))
            q[cols] = np.clip(q[cols] + pinv @ err + null, self.lower[cols], self.upper[cols])
        return q, float(np.linalg.norm(ep)), float(np.linalg.norm(eo))

    def check_reach(self, position: Vec3, yaw: float = 0.0, orientation: Quat | None = None) -> str:
        """Can the end effector be put at ``position`` (metres, world; tool pointing down with ``yaw`` unless an
        ``orientation`` is given)? Solved from the ready pose with the configured tolerances, before any tick
        (no joint state is written). Returns "" if so, else the reason, starting with "unreachable".
        """
        cfg: IkArmConfig = self.config
        pos = np.asarray(position, float)
        orn = orientation if orientation is not None else down_quaternion(yaw)
        where = f"({pos[0]:.3f}, {pos[1]:.3f}, {pos[2]:.3f})"
        dist_base = float(np.linalg.norm(pos - self.base_pos))
        if cfg.reach is not None and dist_base > cfg.reach:
            return f"unreachable: {where} is {dist_base:.3f} m from the base, reach is {cfg.reach:g} m"
        tolerance = max(cfg.ik_tolerance, 1e-3)
        q = self.ready.copy()
        ep = eo = math.inf
        start_pos, start_orn = self.chain.fk(q)
        steps = max(1, math.ceil(float(np.linalg.norm(pos - start_pos)) / cfg.waypoint_spacing),
                    math.ceil(quat_angle(start_orn, orn) / cfg.waypoint_angle))
        for k in range(1, steps + 1):  # along the straight path from the ready pose, as a move would go
            s = k / steps
            q, ep, eo = self._solve(q, start_pos + s * (pos - start_pos), _slerp(start_orn, orn, s))
        for _ in range(REACH_ROUNDS):
            if ep <= tolerance and eo <= cfg.orientation_tolerance / 2:
                return ""
            q, ep, eo = self._solve_numpy(q, pos, orn)
        if ep <= tolerance and eo <= cfg.orientation_tolerance / 2:
            return ""
        return (f"unreachable: IK residual {ep * 1000:.1f} mm / {math.degrees(eo):.1f} deg at {where} "
                f"(tolerance {tolerance * 1000:g} mm)")

    # ------------------------------------------------------------------ commands
    def command(self, cmd: Any) -> None:
        """Accept :class:`MoveTo` (plan a path, or fail with a reason), :class:`FollowJoints` or :class:`HoldArm`.
        After a ``stop_on`` stop, commands are ignored (the arm stays stopped); after a protective stop, the next
        command moves it."""
        if self.latched and isinstance(cmd, (HoldArm, MoveTo, FollowJoints)):
            return
        self.stopped = False
        if isinstance(cmd, HoldArm):
            self.path, self.target = None, None
            self.q_cmd = self._measured_all()[self.arm_cols]
            self.status, self.reason = "idle", ""
            self.command_id += 1
            self._holding = False  # send the new hold target
            return
        if isinstance(cmd, FollowJoints):
            self.command_id += 1
            reason = self._follow(cmd)
            self.status, self.reason = ("failed", reason) if reason else ("moving", "")
            return
        if not isinstance(cmd, MoveTo):
            raise ValueError(f"ik_arm takes MoveTo, FollowJoints or HoldArm, got {type(cmd).__name__}")
        self.command_id += 1
        pos, orn = np.asarray(cmd.position, float), cmd.quaternion()
        self.target = (tuple(float(v) for v in pos), orn)  # type: ignore[assignment]
        reason = self._plan(pos, orn, cmd.speed or self.config.speed)
        if reason:
            self.path, self.status, self.reason = None, "failed", reason
        else:
            self.status, self.reason = "moving", ""

    def _plan(self, pos: np.ndarray, orn: Quat, speed: float) -> str:
        """Solve the path's waypoints; returns a failure reason, or "" with ``self.path`` set."""
        q_all = self._measured_all()
        q_all[self.arm_cols] = self.q_cmd
        qs, reason, dist, ang = self._path(q_all, pos, orn)
        if reason:
            return reason
        self.path = qs
        self.t0 = self.world.time
        self.duration = max(1.5 * dist / speed, 1.5 * ang / self.config.angular_speed, self.config.min_duration)
        self._profile()
        return ""

    def straight_path(self, position: Vec3, orientation: Quat, start: Any = None) -> tuple[list[np.ndarray], str]:
        """The path a :class:`MoveTo` to this pose would take from the arm's joint positions ``start`` (None: its
        commanded ones now): the arm's joint positions per waypoint (the first: the start's), and "" or why the
        move would fail. Nothing moves."""
        q_all = self._measured_all()
        q_all[self.arm_cols] = self.q_cmd if start is None else start
        qs, reason, _, _ = self._path(q_all, np.asarray(position, float), orientation)
        return qs, reason

    def _follow(self, cmd: FollowJoints) -> str:
        """Take a joint-space path (:class:`FollowJoints`); returns a failure reason, or "" with ``self.path`` set."""
        arm_names = [j.name for j in self.arm]
        unknown = [name for name in cmd.joints if name not in arm_names]
        if unknown:
            self.path = None
            return f"unknown arm joint {unknown[0]!r}; arm joints: {', '.join(arm_names)}"
        cols = [arm_names.index(name) for name in cmd.joints]
        qs = [self.q_cmd.copy()]
        for point in cmd.path:
            q = qs[-1].copy()
            q[cols] = point
            qs.append(q)
        lo, hi = self.lower[self.arm_cols], self.upper[self.arm_cols]
        if any(np.any(q < lo - 1e-6) or np.any(q > hi + 1e-6) for q in qs):
            self.path = None
            return "joint path outside the joint limits"
        q_all = np.tile(self._measured_all(), (len(qs), 1))
        q_all[:, self.arm_cols] = qs
        positions, _ = self.chain.fk_many(q_all)
        dist = float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1)))
        travel = float(np.max(np.sum(np.abs(np.diff(np.array(qs), axis=0)), axis=0)))
        pos, orn = self.chain.fk(q_all[-1])
        self.target = (tuple(float(v) for v in pos), orn)  # type: ignore[assignment]
        self.path, self.t0 = qs, self.world.time
        speed = cmd.speed or self.config.speed
        self.duration = max(1.5 * dist / speed, 1.5 * travel / cmd.joint_speed, self.config.min_duration)
        self._profile()
        return ""

    def _path(self, q_all: np.ndarray, pos: np.ndarray, orn: Quat) -> tuple[list[np.ndarray], str, float, float]:
        """The straight path from joint configuration ``q_all`` to the tool pose (pos, orn), solved waypoint by
        waypoint: (the arm's joint positions per waypoint, starting with the current ones; "" or the reason it is
        unreachable; its length in metres; its turn in radians). What a move does, and what validate checks."""
        cfg: IkArmConfig = self.config
        dist_base = float(np.linalg.norm(pos - self.base_pos))
        if cfg.reach is not None and dist_base > cfg.reach:
            return [], (f"unreachable: target {_where(pos)} is {dist_base:.3f} m from the base, reach is "
                        f"{cfg.reach:g} m"), 0.0, 0.0
        start_pos, start_orn = self.chain.fk(q_all)
        dist, ang = float(np.linalg.norm(pos - start_pos)), quat_angle(start_orn, orn)
        n = max(1, math.ceil(dist / cfg.waypoint_spacing), math.ceil(ang / cfg.waypoint_angle))
        qs = [q_all[self.arm_cols].copy()]
        fractions = np.arange(1, n + 1) / n
        positions = start_pos + fractions[:, None] * (pos - start_pos)
        poses = [(p_k, _slerp(start_orn, orn, float(s))) for p_k, s in zip(positions, fractions, strict=True)]
        for k, (q_k, ep, eo) in enumerate(self._solve_path(q_all, poses), start=1):
            if ep > max(cfg.ik_tolerance, 1e-3) or eo > cfg.orientation_tolerance / 2:
                return qs, (f"unreachable: IK residual {ep * 1000:.1f} mm / {math.degrees(eo):.1f} deg at waypoint "
                            f"{k}/{n} towards {_where(pos)} (tolerance {cfg.ik_tolerance * 1000:g} mm)"), dist, ang
            qs.append(q_k[self.arm_cols].copy())
        return qs, "", dist, ang

    def check_moves(self, moves: list[tuple[Vec3, float]], start: Any = None) -> tuple[list[str], Any]:
        """Would these moves (tool positions in metres, world, tool pointing down with a yaw in radians), made one
        after the other, all be planned? The same path solver, waypoints and tolerances as :meth:`command`, before
        any tick (no joint state is written).

        Args:
            moves: The moves, in order.
            start: Where the first starts: a configuration an earlier call returned; None = the ready pose.

        Returns:
            One reason per move ("" = it would be planned; after a move that would fail, the next starts where the
            last good one ended, as in a run) and the configuration the last good move ends in.
        """
        q_all = self.ready.copy() if start is None else np.array(start, float)
        out = []
        for position, yaw in moves:
            qs, reason, _, _ = self._path(q_all, np.asarray(position, float), down_quaternion(yaw))
            out.append(reason)
            if not reason:
                q_all = q_all.copy()
                q_all[self.arm_cols] = qs[-1]
        return out, q_all

    def _profile(self) -> None:
        """Joint targets and feed-forward velocities for every tick of the path, computed once (numpy).

        Row ``k`` is what the motors get ``k`` ticks after the command: the waypoints interpolated at the smooth
        (zero end-velocity) time profile, and the difference to the next row over one time step.
        """
        assert self.path is not None
        dt = self.world.time_step
        ks = np.arange(math.ceil(self.duration / dt) + 2)
        x = ks * dt / self.duration
        s = np.clip(x, 0.0, 1.0)
        s = s * s * (3.0 - 2.0 * s) * (len(self.path) - 1)
        points = np.array(self.path)
        if len(points) > 1:
            k = np.minimum(s.astype(int), len(points) - 2)
            f = (s - k)[:, None]
            q = (1.0 - f) * points[k] + f * points[k + 1]
        else:
            q = np.repeat(points, len(ks), axis=0)
        self._rows = int(np.count_nonzero(x < 1.0))  # rows while the path runs; then the last point is held
        self._q, self._qd = q, (q[1:] - q[:-1]) / dt
        self._q_rows, self._qd_rows = q.tolist(), self._qd.tolist()  # what the motors get, ready to send
        self._tick0 = self.world.tick

    # ------------------------------------------------------------------ per tick
    def protective_stop(self, reason: str) -> None:
        """Stop now, before this tick's physics step: hold the measured joint positions with zero target
        velocity, drop the path. The reading says ``failed`` (``stopped``) with the reason until a new command."""
        self.path, self.target = None, None
        self.q_cmd = self._measured_all()[self.arm_cols]
        self.status, self.reason, self.stopped = "failed", f"protective stop: {reason}", True
        self._apply(self.q_cmd, None)
        self.ctx.trace("protective_stop", actuator=self.name, reason=reason)

    def _check_stop_on(self) -> None:
        contact = self.ctx.readings[self.config.stop_on]
        if contact.in_contact and contact.normal_force > self.config.stop_force:
            touched = ", ".join(contact.others) or "something"
            self.protective_stop(f"contact with {touched} ({contact.normal_force:.1f} N) at t = "
                                 f"{self.world.time:.3f} s ({self.config.stop_on})")
            self.latched = True

    def update(self) -> None:
        """Send this tick's joint targets (with feed-forward velocity) to the motors; once the path is over (or
        with no path), the hold target is sent once and nothing after it. With ``stop_on``, a contact first
        stops the arm for good."""
        if self.config.stop_on is not None and not self.latched:
            self._check_stop_on()
        if self.path is not None:
            row = self.world.tick - self._tick0
            if row < self._rows:
                self.q_cmd = self._q[row]
                self._send(self._q_rows[row], self._qd_rows[row])
                return
            if not self._holding:
                self.q_cmd = self.path[-1]
        if not self._holding:
            self._apply(self.q_cmd, None)

    def _apply(self, q: np.ndarray, qd: np.ndarray | None) -> None:
        """Send joint targets (``qd`` None: hold, zero target velocity)."""
        self._send(q.tolist(), None if qd is None else qd.tolist())

    def _send(self, q: list[float], qd: list[float] | None) -> None:
        self._holding = qd is None
        self.world.set_joint_motors(
            self.body, self._indices, "position", target_positions=q,
            target_velocities=self._zero if qd is None else qd, forces=self.forces,
            position_gains=self._gains[0], velocity_gains=self._gains[1],
        )

    def read(self) -> ArmState:
        """End-effector pose and the state of the current target (see :class:`ArmState`)."""
        w = self.world
        pos, orn = w.pose(self.body, self.ee)
        if self._has_tool:
            pos, orn = w.multiply_transforms(pos, orn, *self._tool)
        ep = eo = 0.0
        target = self.target
        if target is not None:
            ep = math.dist(pos, target[0])
            to = target[1]
            eo = 2.0 * math.acos(min(1.0, abs(orn[0] * to[0] + orn[1] * to[1] + orn[2] * to[2] + orn[3] * to[3])))
        self._update_status(ep, eo)
        states = w.joint_states(self.body, self._movable_indices)
        return ArmState(
            position=pos, orientation=orn, status=self.status, reason=self.reason,
            target_position=target[0] if target else None, target_orientation=target[1] if target else None,
            position_error=ep, orientation_error=eo, command_id=self.command_id,
            joint_positions=dict(zip(self._names, [st[0] for st in states], strict=True)),
            path_end=self.t0 + self.duration if self.path is not None else None, stopped=self.stopped,
        )

    def _update_status(self, ep: float, eo: float) -> None:
        cfg: IkArmConfig = self.config
        if self.status != "moving" or self.path is None:
            return
        elapsed = self.world.time - self.t0
        if elapsed < self.duration:
            self.status = "moving"
        elif ep <= cfg.position_tolerance and eo <= cfg.orientation_tolerance:
            self.status = "reached"
        elif elapsed > self.duration + cfg.settle_timeout:
            self.status = "failed"
            self.reason = (f"did not reach the target: {ep * 1000:.1f} mm / {math.degrees(eo):.1f} deg off "
                           f"{cfg.settle_timeout:g} s after the path ended (blocked?)")


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("ik_arm", IkArm, IkArmConfig)
