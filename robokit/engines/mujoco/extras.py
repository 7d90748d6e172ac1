"""The rest of the World interface on the mujoco engine: pose arithmetic and camera matrices (numpy), and what is
not built yet, each refused with one line naming the engine (configs that need them are refused before the run by
:mod:`robokit.engines.mujoco.support`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import NoReturn

from robokit.engines.interface import Pose, Quat, Vec3
from robokit.engines.mujoco import spatial as mm
from robokit.errors import UserError


def _not_yet(what: str) -> NoReturn:
    raise UserError(f"{what} is not built on the mujoco engine yet (--engine pybullet has it)")


class MujocoExtras:
    """Mixed into :class:`~robokit.engines.mujoco.world.MujocoWorld` before the World interface."""

    # ----------------------------------------------------------------- pose arithmetic
    def multiply_transforms(self, position_a: Sequence[float], orientation_a: Sequence[float],
                            position_b: Sequence[float], orientation_b: Sequence[float]) -> Pose:
        return mm.multiply(position_a, orientation_a, position_b, orientation_b)

    def invert_transform(self, position: Sequence[float], orientation: Sequence[float]) -> Pose:
        return mm.invert(position, orientation)

    def quaternion_from_euler(self, rpy: Sequence[float]) -> Quat:
        return mm.from_euler(rpy)

    def euler_from_quaternion(self, quaternion: Sequence[float]) -> Vec3:
        return mm.to_euler(quaternion)

    def matrix_from_quaternion(self, quaternion: Sequence[float]) -> tuple[float, ...]:
        return mm.matrix(quaternion)

    def view_matrix(self, eye: Sequence[float], target: Sequence[float], up: Sequence[float]) -> tuple[float, ...]:
        return mm.look_at(eye, target, up)

    def projection_matrix(self, fov_deg: float, aspect: float, near: float, far: float) -> tuple[float, ...]:
        return mm.perspective(fov_deg, aspect, near, far)

    def image_sample_offset(self, renderer: str) -> float:
        return 0.5

    # ----------------------------------------------------------------- GUI (none on mujoco)
    def debug_line(self, start: Sequence[float], end: Sequence[float], rgb: Sequence[float], *,
                   lifetime: float = 0.0) -> None:
        """No viewer: nothing to draw on."""

    def key_events(self) -> Mapping[int, int]:
        """No viewer: no keys."""
        return {}
