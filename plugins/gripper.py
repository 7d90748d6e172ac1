"""``gripper`` actuator: a parallel two-finger gripper (Panda by default) that grasps by friction.

The two finger joints are named in config. They are coupled by a gear constraint (ratio -1) so they stay
symmetric when contact forces push them unevenly; both are also position-controlled with the same target and a
moderate force limit. Finger lateral friction is raised (default 1.2) so a squeezed object is held by friction, as
on a real robot; nothing is welded to the hand.

Readings (:class:`~robokit.msgs.arm.GripperState`): the finger width (metres, the sum of the two finger
joint positions), ``settled`` (width steady for ``settle_time``), ``holding`` (both fingers touch the same body and
the width is above ``empty_width``, i.e. the fingers did not close on nothing) and the held body's name.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import GripperCommand, GripperState


class GripperConfig(Schema):
    """``[actuators.NAME]`` with ``type = "gripper"``. Widths in metres, forces in newtons, times in sim seconds."""

    body: str = Field(description="the robot's body name")
    finger_joints: tuple[str, str] = ("panda_finger_joint1", "panda_finger_joint2")
    open_width: float | None = Field(None, gt=0, description="default: both fingers at their upper limit")
    force: float = Field(20.0, gt=0, description="finger force limit when closing, N")
    finger_speed: float = Field(0.2, gt=0, description="max finger speed, m/s")
    lateral_friction: float = Field(1.2, ge=0)
    spinning_friction: float = Field(0.002, ge=0)
    couple: bool = Field(True, description="gear constraint (ratio -1) between the fingers")
    gear_erp: float = Field(0.1, gt=0, le=1)
    gear_max_force: float = Field(50.0, gt=0)
    empty_width: float = Field(0.004, ge=0, description="closed on nothing below this width")
    settle_time: float = Field(0.04, ge=0)
    settle_speed: float = Field(0.01, gt=0, description="width change below this (m/s) counts as still")
    start_open: bool = True


class Gripper(Actuator):
    """A two-finger parallel gripper: open / close with a force limit / go to a width; grasps by friction."""

    reading_type = GripperState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "panda"},
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
        "commands": [(0, GripperCommand("close")), (24, GripperCommand("width", width=0.05))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: GripperConfig = self.config
        w = self.world
        self.body = ctx.body(cfg.body)
        self.fingers = []
        for i, name in enumerate(cfg.finger_joints):
            info = ctx.joint(cfg.body, name, key=f"finger_joints[{i}]")
            if info.type != "prismatic":
                raise ConfigError(f"finger joint {name!r} must be prismatic, got {info.type}",
                                  key=f"finger_joints[{i}]")
            self.fingers.append(info)
        self.max_width = sum(j.upper for j in self.fingers)
        self.open_width = min(cfg.open_width or self.max_width, self.max_width)
        self.links = {j.index for j in self.fingers}
        for j in self.fingers:
            w.client.changeDynamics(self.body, j.index, lateralFriction=cfg.lateral_friction,
                                    spinningFriction=cfg.spinning_friction, frictionAnchor=True)
        self.gear = None
        if cfg.couple:
            self._couple()
        self.action, self.target, self.force = "open", self.open_width, cfg.force
        start = self.open_width / 2 if cfg.start_open else 0.0
        for j in self.fingers:
            w.client.resetJointState(self.body, j.index, start)
        self.target = self.open_width if cfg.start_open else 0.0
        self._indices = [j.index for j in self.fingers]
        self._dirty = True  # motor targets to send at the next update
        self._last_width = self._width()
        self._still_since: float | None = self.world.time
        self._last_t = self.world.time
        self._tracking = True  # watching the width every tick until it has been still for settle_time

    def _couple(self) -> None:
        cfg: GripperConfig = self.config
        c = self.world.client
        a, b = self.fingers
        self.gear = c.createConstraint(self.body, a.index, self.body, b.index, jointType=c.JOINT_GEAR,
                                       jointAxis=[1, 0, 0], parentFramePosition=[0, 0, 0],
                                       childFramePosition=[0, 0, 0])
        c.changeConstraint(self.gear, gearRatio=-1, erp=cfg.gear_erp, maxForce=cfg.gear_max_force)

    def command(self, cmd: Any) -> None:
        """Accept a :class:`GripperCommand` (``open``, ``close`` or ``width``)."""
        if not isinstance(cmd, GripperCommand):
            raise ValueError(f"gripper takes GripperCommand, got {type(cmd).__name__}")
        if cmd.action == "open":
            target = self.open_width
        elif cmd.action == "close":
            target = 0.0
        else:
            assert cmd.width is not None
            target = min(max(cmd.width, 0.0), self.max_width)
        force = cmd.force if cmd.force is not None else self.config.force
        if (cmd.action, target) != (self.action, self.target):
            self._still_since = None
            self._watch()
        if (cmd.action, target, force) != (self.action, self.target, self.force):
            self._dirty = True
        self.action, self.target, self.force = cmd.action, target, force

    def update(self) -> None:
        """Drive both fingers to half the target width each, within the force and speed limits (sent when the
        command changes; the motors keep their targets), and watch the width while it may still be moving."""
        if self._dirty:
            c = self.world.client
            for j in self.fingers:
                c.setJointMotorControl2(self.body, j.index, c.POSITION_CONTROL, targetPosition=self.target / 2,
                                        force=self.force, maxVelocity=self.config.finger_speed)
            self._dirty = False
        if self._tracking:
            self._track_settling()

    def _width(self) -> float:
        states = self.world.client.getJointStates(self.body, self._indices)
        return float(states[0][0] + states[1][0])

    def _watch(self) -> None:
        """Start watching the width every tick again (after a new command, or fingers found moving)."""
        if not self._tracking:
            self._tracking = True
            self._last_width, self._last_t = self._width(), self.world.time

    def _track_settling(self) -> None:
        cfg: GripperConfig = self.config
        now, width = self.world.time, self._width()
        dt = max(now - self._last_t, self.world.time_step)
        moving = abs(width - self._last_width) / dt > cfg.settle_speed
        if moving:
            self._still_since = None
        elif self._still_since is None:
            self._still_since = now
        elif now - self._still_since >= cfg.settle_time:
            self._tracking = False  # settled: from now on a read checks the finger speed instead
        self._last_width, self._last_t = width, now

    def _finger_touches(self) -> tuple[list[set[int]], int]:
        c = self.world.client
        touched: list[set[int]] = []
        total = 0
        for j in self.fingers:
            bodies = set()
            for cp in c.getContactPoints(bodyA=self.body, linkIndexA=j.index):
                if cp[2] != self.body:
                    bodies.add(cp[2])
                    total += 1
            touched.append(bodies)
        return touched, total

    def read(self) -> GripperState:
        """Width, settling, and whether (and what) the fingers hold."""
        cfg: GripperConfig = self.config
        states = self.world.client.getJointStates(self.body, self._indices)
        width = float(states[0][0] + states[1][0])
        if not self._tracking and abs(states[0][1] + states[1][1]) > cfg.settle_speed:
            self._still_since = None  # settled fingers pushed open or shut: moving again
            self._watch()
        touched, total = self._finger_touches()
        common = sorted(touched[0] & touched[1])
        holding = bool(common) and self.action != "open" and width > cfg.empty_width
        held = None
        if holding:
            held = self.world.body_name(common[0]) or f"body{common[0]}"
        settled = self._still_since is not None and self.world.time - self._still_since >= cfg.settle_time
        return GripperState(width=width, target_width=self.target, action=self.action, settled=settled,
                            holding=holding, held=held, finger_contacts=total)

    def close(self) -> None:
        if self.gear is not None and self.world.client is not None:
            try:
                self.world.client.removeConstraint(self.gear)
            except Exception:  # noqa: BLE001 - the world may already be gone
                pass
            self.gear = None


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("gripper", Gripper, GripperConfig)
