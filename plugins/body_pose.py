"""``body_pose`` sensor: ground-truth pose and velocity of named bodies.

For scenes and tests where perception is not the point (lesson 01's drop test, pick-and-place of a known object).
Perception-based behaviours must use the camera/lidar instead.
"""

from __future__ import annotations

from typing import NamedTuple

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema

Vec3 = tuple[float, float, float]


class BodyPoseConfig(Schema):
    """``bodies``: names to track (empty = every body with mass)."""

    bodies: tuple[str, ...] = ()


class BodyState(NamedTuple):
    """Pose and velocity of one body's base: metres, ``(x, y, z, w)`` quaternion, m/s and rad/s, world frame."""

    position: Vec3
    orientation: tuple[float, float, float, float]
    linear_velocity: Vec3
    angular_velocity: Vec3


class BodyPoseSensor(Sensor):
    """Ground-truth pose and velocity of named bodies (a dict of name -> BodyState)."""

    # Poses are in each body's link frame (what its URDF and the config's `position` mean); the linear velocity is
    # that of its centre of mass (see World.pose / World.com_pose).

    reading_type = dict
    example = {  # for robokit.testing.check_sensor
        "config": {"bodies": ["ball"]},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "ball": {"shape": "sphere", "radius": 0.05, "position": [0, 0, 0.3]}},
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        names = self.config.bodies if self.config else ()
        for i, name in enumerate(names):
            ctx.body(name, key=f"bodies[{i}]")
        if not names:
            names = tuple(n for n in self.world.body_names if self.world.mass(n) > 0)
        self.names = names
        self._all = [(name, self.world.body(name)) for name in names]  # looked up once, at load
        self._ids, self._removals = list(self._all), 0
        self._bids = [bid for _, bid in self._ids]

    def reset(self, rng: object = None) -> None:
        """Nothing to reset between robokit.gym episodes: a reading depends only on the world."""

    def read(self) -> dict[str, BodyState]:
        world = self.world
        if world.removals != self._removals:  # a body was removed during the run: drop it from the list
            self._ids = [(n, b) for n, b in self._all if world.body_name(b) == n]
            self._bids = [bid for _, bid in self._ids]
            self._removals = world.removals
        new = tuple.__new__  # builds the named tuple without its Python-level __new__ (hot path)
        return {name: new(BodyState, state)
                for (name, _), state in zip(self._ids, world.body_states(self._bids), strict=True)}


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("body_pose", BodyPoseSensor, BodyPoseConfig)
