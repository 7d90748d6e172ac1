"""robokit-example-imu: an IMU sensor plugin for robokit (a worked example of a third-party plugin package).

robokit finds this module through the entry point ``imu = "robokit_example_imu"`` in the ``robokit`` group
(see ``pyproject.toml``) and calls the ``@hookimpl`` functions below once per simulation.
"""

from __future__ import annotations

from typing import Any

from robokit import hookimpl

from robokit_example_imu.imu import ImuConfig, ImuSensor
from robokit_example_imu.types import ImuReading

__version__ = "0.1.0"
__all__ = ["ImuConfig", "ImuReading", "ImuSensor", "__version__"]


@hookimpl
def robokit_register_sensors(register: Any) -> None:
    """Register the ``imu`` sensor type with its config schema."""
    register("imu", ImuSensor, ImuConfig)
