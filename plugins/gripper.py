"""``gripper`` actuator: any parallel gripper, set up by config, that grasps by friction.

Defaults fit the Panda (two prismatic finger joints). Other grippers are described by their joints:

- ``finger_joints``: one joint per finger (two for a two-finger gripper), prismatic **or** revolute, or a single
  driven joint whose followers are listed in ``mimic`` (joint name -> ratio to the driven joint; each follower is
  tied to it with a gear constraint, like a URDF ``<mimic>`` tag, which pybullet does not enforce by itself);
- ``open_positions`` / ``closed_positions``: each finger joint's position (m or rad) when open and when closed
  (default: upper limit open, 0 closed, the Panda's convention);
- ``hold_joints``: other joints held at a fixed position (e.g. fingertip hinges), so they do not flop;
- ``open_width``: the distance between the fingertips when fully open, metres (default for prismatic fingers: the
  sum of their travels from closed to open, their open positions when they close at 0). Widths in commands and
  readings are metres; in between, width is taken as linear in the fingers' travel from closed to open.

With two fingers they are coupled by a gear constraint (ratio from their travel directions) so they stay symmetric
when contact forces push them unevenly; each is position-controlled with a moderate force limit. Finger lateral
friction is raised (default 1.2) so a squeezed object is held by friction, as on a real robot; nothing is welded.

Readings (:class:`~robokit.msgs.arm.GripperState`): ``width``, ``settled`` (width steady for ``settle_time``,
watched tick by tick after each command; with ``watch_settling = false``, finger speed below ``settle_speed`` when
read, and no joint reads between readings), ``holding`` (both fingers — each finger joint's child link and every
link below it, or the links named in ``finger_links`` — touch the same body and the width is above
``empty_width``) and the held body's name.
"""

from __future__ import annotations

from typing import Any, ClassVar

from pydantic import Field, model_validator

from robokit import hookimpl
from robokit.components import Actuator, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.arm import ContactState, GripperCommand, GripperState


class GripperConfig(Schema):
    """``[actuators.NAME]`` with ``type = "gripper"``. Widths in metres, forces in newtons, times in sim seconds."""

    body: str = Field(description="the robot's body name")
    finger_joints: list[str] = Field(["panda_finger_joint1", "panda_finger_joint2"], min_length=1, max_length=2,
                                     description="one joint per finger, or one driven joint with 'mimic'")
    open_positions: list[float] | None = Field(None, description="per finger joint, m or rad; default upper limit")
    closed_positions: list[float] | None = Field(None, description="per finger joint, m or rad; default 0")
    mimic: dict[str, float] = Field(default_factory=dict, description="follower joint -> ratio to the driven one")
    hold_joints: dict[str, float] = Field(default_factory=dict, description="joint -> position held throughout")
    finger_links: list[list[str]] | None = Field(
        None, min_length=2, max_length=2, description="the links of each finger for grasp checks")
    open_width: float | None = Field(None, gt=0, description="fingertip distance when open, m")
    force: float = Field(20.0, gt=0, description="finger force limit when closing, N (N·m for revolute)")
    finger_speed: float = Field(0.2, gt=0, description="max finger speed, m/s of width change per finger")
    lateral_friction: float = Field(1.2, ge=0)
    spinning_friction: float = Field(0.002, ge=0)
    couple: bool = Field(True, description="gear constraint between two fingers")
    gear_erp: float = Field(0.1, gt=0, le=1)
    gear_max_force: float = Field(50.0, gt=0)
    empty_width: float = Field(0.004, ge=0, description="closed on nothing below this width")
    settle_time: float = Field(0.04, ge=0)
    settle_speed: float = Field(0.01, gt=0, description="width change below this (m/s) counts as still")
    watch_settling: bool = Field(True, description="after a command, read the finger joints every tick until the "
                                 "width has been still for settle_time (what 'settled' means); false: no reads "
                                 "between readings, and 'settled' means the fingers move slower than settle_speed "
                                 "when read (for learning envs, whose actions move the fingers every step and never "
                                 "read 'settled')")
    stop_on: str | None = Field(None, description="a contact sensor: a contact (above stop_force) freezes the "
                                "fingers for the rest of the run")
    stop_force: float = Field(0.0, ge=0, description="contact normal force that triggers stop_on, N")
    start_open: bool = True

    @model_validator(mode="after")
    def _shapes(self) -> GripperConfig:
        n = len(self.finger_joints)
        for key in ("open_positions", "closed_positions"):
            value = getattr(self, key)
            if value is not None and len(value) != n:
                raise ValueError(f"'{key}' needs one value per finger joint ({n}), got {len(value)}")
        if n == 1 and self.finger_links is None:
            raise ValueError("a single driven finger joint needs 'finger_links' (the links of each finger)")
        return self


class Gripper(Actuator):
    """A parallel gripper: open / close with a force limit / go to a width; grasps by friction."""

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
            if info.type not in ("prismatic", "revolute"):
                raise ConfigError(f"finger joint {name!r} must be prismatic or revolute, got {info.type}",
                                  key=f"finger_joints[{i}]")
            self.fingers.append(info)
        self.open_q = list(cfg.open_positions or [j.upper for j in self.fingers])
        self.closed_q = list(cfg.closed_positions or [0.0] * len(self.fingers))
        if any(o == c for o, c in zip(self.open_q, self.closed_q, strict=True)):
            raise ConfigError("each finger joint's open and closed positions must differ", key="open_positions")
        prismatic = all(j.type == "prismatic" for j in self.fingers) and len(self.fingers) == 2
        default_width = sum(abs(o - c) for o, c in zip(self.open_q, self.closed_q, strict=True)) if prismatic else None
        if cfg.open_width is None and default_width is None:
            raise ConfigError("give 'open_width' (fingertip distance when open, metres) for revolute or "
                              "single-joint fingers", key="open_width")
        self.max_width = self.open_width = float(cfg.open_width or default_width or 0.0)
        self.followers = [(ctx.joint(cfg.body, n, key=f"mimic.{n}"), r) for n, r in cfg.mimic.items()]
        self.held_joints = [(ctx.joint(cfg.body, n, key=f"hold_joints.{n}"), q) for n, q in cfg.hold_joints.items()]
        self.links = self._finger_link_sets(ctx)
        if cfg.stop_on is not None and getattr(ctx.components.get(cfg.stop_on), "reading_type", None) is not \
                ContactState:
            raise ConfigError(f"{cfg.stop_on!r} is not a contact sensor; components: {', '.join(ctx.components)}",
                              key="stop_on")
        self._side = {link: i for i, links in enumerate(self.links) for link in links}  # link -> finger
        for link in set().union(*self.links):
            w.set_dynamics(self.body, link, lateral_friction=cfg.lateral_friction,
                           spinning_friction=cfg.spinning_friction, friction_anchor=True)
        self.gears: list[int] = []
        if cfg.couple and len(self.fingers) == 2:
            a, b = self.fingers
            ratio = (self.open_q[1] - self.closed_q[1]) / (self.open_q[0] - self.closed_q[0])
            self.gears.append(self._gear(a.index, b.index, ratio))
        for follower, ratio in self.followers:
            # A follower is moved by its gear only: switch off the default velocity motor that would hold it.
            w.set_joint_motor(self.body, follower.index, "velocity", force=0.0)
            self.gears.append(self._gear(self.fingers[0].index, follower.index, ratio))
        self.reset()

    def reset(self, rng: Any = None) -> None:
        """The start state (also between robokit.gym episodes): fingers open or closed as configured, at rest, not
        stopped (neither a protective stop nor a ``stop_on`` stop carries over)."""
        cfg: GripperConfig = self.config
        w = self.world
        self.stopped = self.latched = False
        self.action, self.force = "open", cfg.force
        self.target = self.open_width if cfg.start_open else 0.0
        for j, q in zip(self.fingers, self._joint_targets(self.target), strict=True):
            w.reset_joint(self.body, j.index, q)
        for follower, ratio in self.followers:
            q0 = w.joint_states(self.body, [self.fingers[0].index])[0][0]
            w.reset_joint(self.body, follower.index, ratio * q0)
        for j, q in self.held_joints:
            w.reset_joint(self.body, j.index, q)
        self._speeds = [cfg.finger_speed * abs(o - c) / (self.open_width / 2)
                        for o, c in zip(self.open_q, self.closed_q, strict=True)]
        self._indices = [j.index for j in self.fingers]
        self._spans = [o - c for o, c in zip(self.open_q, self.closed_q, strict=True)]
        self._dirty = True  # motor targets to send at the next update
        self._read_at: tuple[int, float, float] | None = None  # (tick, width, rate) a read measured this tick
        self._last_width = self._width()
        self._still_since: float | None = self.world.time
        self._last_t = self.world.time
        self._tracking = cfg.watch_settling  # watching the width every tick until still for settle_time

    def _finger_link_sets(self, ctx: SetupContext) -> list[set[int]]:
        """Link indices of each finger: configured by name, or each finger joint's child link and its subtree."""
        cfg: GripperConfig = self.config
        if cfg.finger_links is not None:
            return [{ctx.link(cfg.body, name, key=f"finger_links[{i}]") for name in side}
                    for i, side in enumerate(cfg.finger_links)]
        parents = {j.index: self.world.joint_parent(self.body, j.index) for j in self.world.joints(cfg.body)}
        sets = []
        for finger in self.fingers:
            subtree = {finger.index}
            grew = True
            while grew:
                grew = False
                for link, parent in parents.items():
                    if parent in subtree and link not in subtree:
                        subtree.add(link)
                        grew = True
            sets.append(subtree)
        return sets

    def _joint_targets(self, width: float) -> list[float]:
        """Finger joint positions for a width (linear in each joint's travel from closed to open)."""
        f = min(max(width / self.open_width, 0.0), 1.0)
        return [c + f * (o - c) for o, c in zip(self.open_q, self.closed_q, strict=True)]

    def _gear(self, parent: int, child: int, ratio: float) -> int:
        """Tie ``child`` to ``parent``: child position = ratio × parent (a gear constraint)."""
        cfg: GripperConfig = self.config
        return self.world.couple_joints(self.body, parent, child, ratio, erp=cfg.gear_erp,
                                        max_force=cfg.gear_max_force)

    def command(self, cmd: Any) -> None:
        """Accept a :class:`GripperCommand` (``open``, ``close`` or ``width``); ignored after a ``stop_on`` stop."""
        if not isinstance(cmd, GripperCommand):
            raise ValueError(f"gripper takes GripperCommand, got {type(cmd).__name__}")
        if self.latched:
            return
        self.stopped = False
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

    def protective_stop(self, reason: str) -> None:
        """Freeze the fingers now: a grasp that holds something keeps its grip (dropping it is not safe), else
        the fingers hold their current width. The reading says ``stopped`` until a new command."""
        if not (self.action == "close" and self.read().holding):
            self.action, self.target = "width", min(max(self._width(), 0.0), self.max_width)
            self._dirty = True
            self._drive()
        self.stopped = True
        self.ctx.trace("protective_stop", actuator=self.name, reason=reason)

    def update(self) -> None:
        """Drive the fingers to the target width, within the force and speed limits, and hold the held joints
        (sent when the command changes: the motors keep their targets); watch the width while it may be moving.
        With ``stop_on``, a contact first freezes the fingers for good."""
        if self.config.stop_on is not None and not self.latched:
            contact = self.ctx.readings[self.config.stop_on]
            if contact.in_contact and contact.normal_force > self.config.stop_force:
                self.latched = True
                self.protective_stop(f"contact with {', '.join(contact.others) or 'something'} "
                                     f"({contact.normal_force:.1f} N) ({self.config.stop_on})")
        self._drive()

    def _drive(self) -> None:
        """Send the finger targets when they changed; watch the width while it may be moving."""
        if not (self._dirty or self._tracking):
            return
        if self._dirty:
            motor = self.world.set_joint_motor
            for j, q, v in zip(self.fingers, self._joint_targets(self.target), self._speeds, strict=True):
                motor(self.body, j.index, "position", target_position=q, force=self.force, max_velocity=v)
            for j, q in self.held_joints:
                motor(self.body, j.index, "position", target_position=q, force=self.force)
            self._dirty = False
        if self._tracking:
            self._track_settling()

    def _width_and_rate(self) -> tuple[float, float]:
        """Fingertip distance (m) and its rate (m/s), from the finger joints' travel between closed and open
        (the mean over the fingers)."""
        frac = rate = 0.0
        states = self.world.joint_states(self.body, self._indices)
        for state, closed, span in zip(states, self.closed_q, self._spans, strict=True):  # read every carried tick
            frac += (state[0] - closed) / span
            rate += state[1] / span
        scale = self.open_width / len(self._spans)
        return scale * frac, scale * rate

    def _width(self) -> float:
        return self._width_and_rate()[0]

    def _watch(self) -> None:
        """Start watching the width every tick again (after a new command, or fingers found moving)."""
        if not self._tracking and self.config.watch_settling:
            self._tracking = True
            self._last_width, self._last_t = self._width(), self.world.time

    def _track_settling(self) -> None:
        cfg: GripperConfig = self.config
        now, read = self.world.time, self._read_at
        # A read earlier in this tick (the behaviour's, before the actuators update) measured the same joints: no
        # physics step has run since, so its width is this tick's width.
        width = read[1] if read is not None and read[0] == self.world.tick else self._width()
        self._read_at = None
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
        """Bodies each finger touches, and the number of finger contact points with other bodies (one contact
        query for the whole robot, split by link: cheaper than one query per finger link)."""
        side = self._side
        touched: list[set[int]] = [set() for _ in self.links]
        total = 0
        for cp in self.world.contacts(self.body):
            i = side.get(cp.link)
            if i is not None and cp.other != self.body:
                touched[i].add(cp.other)
                total += 1
        return touched, total

    def read(self) -> GripperState:
        """Width, settling, and whether (and what) the fingers hold."""
        cfg: GripperConfig = self.config
        width, rate = self._width_and_rate()
        self._read_at = (self.world.tick, width, rate)
        if not self._tracking and abs(rate) > cfg.settle_speed:
            self._still_since = None  # settled fingers pushed open or shut: moving again
            self._watch()
        touched, total = self._finger_touches()
        common = touched[0] & touched[1]
        holding = bool(common) and self.action != "open" and width > cfg.empty_width
        held = None
        if holding:
            first = min(common)
            held = self.world.body_name(first) or f"body{first}"
        since = self._still_since
        if cfg.watch_settling:
            settled = since is not None and self.world.time - since >= cfg.settle_time
        else:
            settled = abs(rate) <= cfg.settle_speed
        return GripperState(width=width, target_width=self.target, action=self.action, settled=settled,
                            holding=holding, held=held, finger_contacts=total, stopped=self.stopped)

    def close(self) -> None:
        while self.gears and not self.world.closed:
            gear = self.gears.pop()
            try:
                self.world.detach(gear)
            except Exception:  # noqa: BLE001 - the world may already be gone
                pass


@hookimpl
def robokit_register_actuators(register):  # type: ignore[no-untyped-def]
    register("gripper", Gripper, GripperConfig)
