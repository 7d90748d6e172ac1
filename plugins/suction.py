"""``suction`` actuator: a suction cup that holds what it touches, modelled as a constraint.

There is no air flow in a rigid-body engine, so suction is modelled the way most simulators model it: while the cup
is on (``GripperCommand("close")``), the first body that touches the cup's link is attached to it (never the robot
itself, nor a body mounted on it or it on) with a fixed constraint at their relative pose at that moment, with a
force limit (``max_force``, newtons: pull harder — a collision, a heavy object swinging — and the constraint
yields). ``open`` removes the constraint and the object falls free. Nothing is attached while the cup is off, and
only a body in contact can be picked: a cup that stops short of the object holds nothing.

It reads and takes the same messages as ``gripper`` (:class:`~robokit.msgs.arm.GripperCommand` in,
:class:`~robokit.msgs.arm.GripperState` out), so ``pick_place`` and ``sort`` drive it unchanged: set their
``grasp_offset`` so that the tool-centre point lands on the object's top face (half the object's height). The
reported ``width`` is ``open_width`` while the cup is off and 0 while it is on, so a behaviour waiting for an
opened gripper sees it open at once. ``reset()`` (between robokit.gym episodes) lets go and turns the cup off: the
start state of a fresh build.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.msgs.arm import GripperCommand, GripperState


class SuctionConfig(Schema):
    """``[actuators.NAME]`` with ``type = "suction"``. Forces in newtons, lengths in metres."""

    body: str = Field(description="the body carrying the cup (a robot, or a cup body mounted on one)")
    link: str | None = Field(None, description="the cup's link; default the body's base link")
    max_force: float = Field(50.0, gt=0, description="strength of the hold, N")
    open_width: float = Field(0.08, gt=0, description="width reported while the cup is off, m")
    settle_time: float = Field(0.05, ge=0, description="after 'close', settled once holding or after this, s")


class Suction(Actuator):
    """A suction cup: ``close`` attaches the touching body with a constraint, ``open`` releases it."""

    reading_type = GripperState
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "cup"},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "cube": {"shape": "box", "size": [0.05, 0.05, 0.05], "mass": 0.1, "position": [0, 0, 0.025]},
                   "cup": {"shape": "cylinder", "radius": 0.02, "height": 0.02, "mass": 0,
                           "position": [0, 0, 0.06]}},
        "commands": [(0, GripperCommand("close")), (24, GripperCommand("open"))],
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: SuctionConfig = self.config
        self.body = ctx.body(cfg.body)
        self.link = -1 if cfg.link is None else ctx.link(cfg.body, cfg.link, key="link")
        self.constraint: int | None = None
        self.held: int | None = None
        self.reset()

    def reset(self, rng: Any = None) -> None:
        """The start state (also between robokit.gym episodes, after the world's snapshot is restored): the cup off
        and holding nothing (a held body is let go), no protective stop; the reading is a fresh build's."""
        self._release()
        self.on = False
        self.action = "open"
        self.since = self.world.time
        self.stopped = False

    def protective_stop(self, reason: str) -> None:
        """Stop now: what the cup holds stays held (dropping it is not safe); nothing new is picked up."""
        self.on = False
        self.stopped = True
        self.ctx.trace("protective_stop", actuator=self.name, reason=reason)

    def command(self, cmd: Any) -> None:
        """``close``: cup on (attach on contact); ``open`` or ``width``: cup off (release)."""
        if not isinstance(cmd, GripperCommand):
            raise ValueError(f"suction takes GripperCommand, got {type(cmd).__name__}")
        if cmd.action != self.action:
            self.since = self.world.time
        self.action = cmd.action
        self.on = cmd.action == "close"
        self.stopped = False
        if not self.on:
            self._release()

    def update(self) -> None:
        """While on and holding nothing, attach the first body touching the cup."""
        if self.on and self.constraint is None:
            touching = self._touching()
            if touching is not None:
                self._attach(touching)

    def _touching(self) -> int | None:
        own = self.world.attached(self.body)  # the cup, the arm it is mounted on, anything else joined to them
        for cp in self.world.contacts(self.body, link=self.link):
            if cp.other not in own:
                return int(cp.other)
        return None

    def _attach(self, other: int) -> None:
        """A fixed constraint keeping ``other`` where it is relative to the cup (both centre-of-mass frames)."""
        self.constraint = self.world.attach(self.body, self.link, other, max_force=self.config.max_force)
        self.held = other

    def _release(self) -> None:
        if self.constraint is not None:
            self.world.detach(self.constraint)
        self.constraint, self.held = None, None

    def read(self) -> GripperState:
        """``holding`` while a body is attached; width ``open_width`` when off, 0 when on; ``settled`` once
        holding, or ``settle_time`` after the cup was turned on with nothing to hold."""
        width = 0.0 if self.on or self.held is not None else self.config.open_width
        held = None if self.held is None else (self.world.body_name(self.held) or f"body{self.held}")
        contacts = len(self.world.contacts(self.body, link=self.link))
        settled = not self.on or self.held is not None or self.world.time - self.since >= self.config.settle_time
        return GripperState(width=width, target_width=width, action=self.action, settled=settled,
                            holding=self.held is not None, held=held, finger_contacts=contacts, stopped=self.stopped)

    def close(self) -> None:
        if not self.world.closed:
            try:
                self._release()
            except Exception:  # noqa: BLE001 - the world may already be gone
                self.constraint = None


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("suction", Suction, SuctionConfig)
