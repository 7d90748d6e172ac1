"""``force_torque`` sensor: a joint force-torque sensor (a wrist F/T sensor) on a named joint.

PyBullet measures the reaction force and torque a joint transmits once its sensor is switched on
(``enableJointForceTorqueSensor``); this plugin switches it on in ``setup`` and off again in ``close``. The reading
is a :class:`~robokit.msgs.sensing.Wrench` in the frame of the joint's **child link** (its name is the message's
``frame``): what the child receives from the parent through the joint, torque about the child link's origin (the
REP 103 signs stated in :mod:`robokit.msgs.sensing`). On the Panda, ``panda_hand_joint`` measures at the wrist: the
hand hanging still reads the weight of the hand and fingers along the hand's up axis; an arm pressing the hand onto
a table reads the press, pointing down.

Options: ``body``, ``joint`` (names), ``world_frame`` (express the vectors in the world frame instead; ``frame``
is then ``"world"``) and ``noise_std`` (N; Gaussian, drawn per tick from the run's seed, also on the torque in
N·m/m).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.msgs.sensing import Wrench


class ForceTorqueConfig(Schema):
    """``[sensors.NAME]`` with ``type = "force_torque"``."""

    body: str = Field(description="the robot's body name")
    joint: str = Field(description="the joint measured (e.g. panda_hand_joint, the Panda's wrist)")
    world_frame: bool = Field(False, description="report in the world frame instead of the child link's")
    noise_std: float = Field(0.0, ge=0, description="Gaussian noise, N (and N·m), drawn per tick")


class ForceTorqueSensor(Sensor):
    """Force (N) and torque (N·m) a named joint transmits, in its child link's frame (or the world's)."""

    reading_type = Wrench
    example: ClassVar[dict[str, Any] | None] = {
        "config": {"body": "panda", "joint": "panda_hand_joint"},
        "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: ForceTorqueConfig = self.config
        self.body = ctx.body(cfg.body)
        info = ctx.joint(cfg.body, cfg.joint, key="joint")
        self.index = info.index
        self.link_name = str(getattr(info, "child_link", "") or cfg.joint)
        self.frame = "world" if cfg.world_frame else self.link_name
        self.world.enable_joint_wrench(self.body, self.index)
        self.enabled = True

    def read(self) -> Wrench:
        """The joint's reaction wrench from the last physics step."""
        w = self.world
        r = np.asarray(w.joint_states(self.body, [self.index])[0][2], dtype=float)
        if self.config.noise_std > 0:
            r = r + self.ctx.tick_rng().normal(0.0, self.config.noise_std, 6)
        force, torque = r[:3], r[3:]
        if self.config.world_frame:
            rot = np.asarray(w.wrench_frame(self.body, self.index)).reshape(3, 3)
            force, torque = rot @ force, rot @ torque
        return Wrench(force=tuple(float(v) for v in force), torque=tuple(float(v) for v in torque),  # type: ignore[arg-type]
                      frame=self.frame, time=self.world.time)

    def close(self) -> None:
        """Switch the joint's sensor off again (a closed sensor leaves no state behind in the world)."""
        if getattr(self, "enabled", False) and not self.world.closed:
            try:
                self.world.enable_joint_wrench(self.body, self.index, False)
            except Exception:  # noqa: BLE001, S110 - the world may already be gone
                pass
            self.enabled = False


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("force_torque", ForceTorqueSensor, ForceTorqueConfig)
