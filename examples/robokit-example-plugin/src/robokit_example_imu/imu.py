"""``imu`` sensor: an accelerometer and a gyroscope on a named link.

The IMU sits at the link's centre of mass and measures in the link frame (the URDF link frame; for a primitive
body, the body's own axes):

- ``linear_acceleration``: specific force ``R^T (a - g)`` in m/s², where ``a`` is the centre of mass's
  acceleration and ``g`` the world's gravity (both world frame) and ``R`` the link's orientation. An
  accelerometer at rest on a table reads ``+9.81`` along the axis pointing up; in free fall it reads zero.
- ``angular_velocity``: ``R^T omega`` in rad/s.

``a`` is the change of the centre of mass's velocity since the previous sample divided by the time between
them, so the sensor is not lazy (``lazy = False``): it samples on every due tick whether or not anything reads
it. The first sample (at the run's first tick) assumes no acceleration yet. Optional zero-mean Gaussian noise
(``accel_noise_std`` m/s², ``gyro_noise_std`` rad/s, per axis) is drawn from the sensor's own generator,
spawned from the run's seed, so a run is reproducible for a seed.

Config::

    [sensors.imu]
    type = "imu"
    body = "robot"            # a body name from [bodies] / [robots]
    link = "chassis"          # a link name of that body; leave out for the base link
    rate_hz = 120             # samples per sim second (default: every physics tick)
    accel_noise_std = 0.05    # m/s²
    gyro_noise_std = 0.005    # rad/s
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from pydantic import Field
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError

from robokit_example_imu.types import ImuReading


def quat_mul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    """Hamilton product ``a * b`` of quaternions in PyBullet order ``(x, y, z, w)`` (double precision)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quat_conj(q: Sequence[float]) -> tuple[float, float, float, float]:
    """Inverse of a unit quaternion ``(x, y, z, w)``."""
    return (-q[0], -q[1], -q[2], q[3])


class ImuConfig(Schema):
    """Config of the ``imu`` sensor.

    Attributes:
        body: Name of the body the IMU is mounted on.
        link: Name of the link (default: the body's base link).
        accel_noise_std: Standard deviation of the accelerometer noise per axis, m/s² (0 = none).
        gyro_noise_std: Standard deviation of the gyroscope noise per axis, rad/s (0 = none).
    """

    body: str
    link: str | None = None
    accel_noise_std: float = Field(0.0, ge=0.0, description="m/s² per axis")
    gyro_noise_std: float = Field(0.0, ge=0.0, description="rad/s per axis")


class ImuSensor(Sensor):
    """IMU on a named link: specific force (m/s²) and angular velocity (rad/s) in the link frame."""

    lazy = False  # finite differences need every due sample
    reading_type = ImuReading
    example: ClassVar[dict[str, Any]] = {
        "config": {"body": "box", "accel_noise_std": 0.05, "gyro_noise_std": 0.01},
        "bodies": {
            "plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
            "box": {"shape": "box", "size": [0.2, 0.1, 0.05], "position": [0, 0, 0.3],
                    "rpy_deg": [20, 10, 0]},
        },
    }

    def setup(self, ctx: SetupContext) -> None:
        """Resolve the body and link by name; read gravity; take the first velocity sample."""
        super().setup(ctx)
        cfg: ImuConfig = self.config
        if not self.world.has_body(cfg.body):
            raise ConfigError(str(LookupNameError("body", cfg.body, self.world.body_names)), key="body")
        self.body_id = self.world.body(cfg.body)
        self.link = -1
        self.frame = cfg.link or self.world.base_link_name(cfg.body) or cfg.body  # named in every reading
        if cfg.link is not None:
            try:
                self.link = self.world.link(cfg.body, cfg.link)
            except LookupNameError as exc:
                raise ConfigError(str(exc), key="link") from None
        params = self.world.client.getPhysicsEngineParameters()
        self.gravity = np.array([params[f"gravityAcceleration{axis}"] for axis in "XYZ"], dtype=float)
        self.base_inertial_orn = self.world.client.getDynamicsInfo(self.body_id, -1)[4]
        self.rng = ctx.rng
        self.prev_velocity, _, _ = self._state()
        self.prev_time = self.world.time

    def _state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centre-of-mass linear velocity (m/s) and angular velocity (rad/s), world frame, and the rotation
        matrix of the link frame (its axes as columns, world frame)."""
        client = self.world.client
        if self.link == -1:
            lin, ang = client.getBaseVelocity(self.body_id)
            _, com_orn = client.getBasePositionAndOrientation(self.body_id)
            orn = quat_mul(com_orn, quat_conj(self.base_inertial_orn))  # centre-of-mass frame -> link frame
        else:
            state = client.getLinkState(self.body_id, self.link, computeLinkVelocity=1,
                                        computeForwardKinematics=1)
            orn, lin, ang = state[5], state[6], state[7]
        rot = np.asarray(client.getMatrixFromQuaternion(orn), dtype=float).reshape(3, 3)
        return np.asarray(lin, dtype=float), np.asarray(ang, dtype=float), rot

    def read(self) -> ImuReading:
        """Sample now: specific force and angular velocity in the link frame (plus noise, if configured)."""
        cfg: ImuConfig = self.config
        velocity, omega, rot = self._state()
        elapsed = self.world.time - self.prev_time
        accel = (velocity - self.prev_velocity) / elapsed if elapsed > 0 else np.zeros(3)
        self.prev_velocity, self.prev_time = velocity, self.world.time
        specific_force = rot.T @ (accel - self.gravity)
        gyro = rot.T @ omega
        if cfg.accel_noise_std > 0:
            specific_force = specific_force + self.rng.normal(0.0, cfg.accel_noise_std, 3)
        if cfg.gyro_noise_std > 0:
            gyro = gyro + self.rng.normal(0.0, cfg.gyro_noise_std, 3)
        fx, fy, fz = (float(v) for v in specific_force)
        wx, wy, wz = (float(v) for v in gyro)
        return ImuReading(linear_acceleration=(fx, fy, fz), angular_velocity=(wx, wy, wz), frame=self.frame,
                          time=self.world.time)

    def close(self) -> None:
        """Nothing to release: the IMU creates no bodies, constraints or debug items. Safe to call twice."""
