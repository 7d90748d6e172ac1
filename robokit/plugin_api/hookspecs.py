"""Every hook robokit calls, in one place. Each is a function with only a docstring.

Plugins implement them with :data:`robokit.hookimpl`. Registration hooks receive a ``register`` callback rather than
returning lists, so one plugin module can register several types::

    from robokit import hookimpl

    @hookimpl
    def robokit_register_sensors(register):
        register("imu", ImuSensor, ImuConfig)

``register(type_name, cls, schema)`` takes the type name used in configs (``type = "imu"``), the class, and a
schema that validates the type's config section: a pydantic model (a ``robokit.config.Schema`` subclass) or a light
``robokit.config.sections.Section`` (no pydantic import; see ``docs/plugins.md``), ``None`` for a type with no options.
"""

from __future__ import annotations

from typing import Any

import pluggy

hookspec = pluggy.HookspecMarker("robokit")


@hookspec
def robokit_register_sensors(register: Any) -> None:
    """Register sensor types. Called once per plugin manager, before any config is read."""


@hookspec
def robokit_register_actuators(register: Any) -> None:
    """Register actuator types. Called once per plugin manager, before any config is read."""


@hookspec
def robokit_register_behaviours(register: Any) -> None:
    """Register behaviour types. Called once per plugin manager, before any config is read."""


@hookspec
def robokit_register_reporters(register: Any) -> None:
    """Register reporter types (deliver a finished run's result). Called once per plugin manager."""


@hookspec
def robokit_register_tasks(register: Any) -> None:
    """Register task types for :mod:`robokit.gym` (reward, success, episode reset). Called once per plugin manager."""


@hookspec
def robokit_run_start(simulation: Any) -> None:
    """Called after every component is set up, just before the first tick."""


@hookspec
def robokit_run_end(simulation: Any, result: Any) -> None:
    """Called once the loop has stopped, with the :class:`robokit.core.result.RunResult`, before reporting."""
