"""``guard`` behaviour: a safety monitor that ends ``aborted`` when a force limit is crossed.

Run it as a monitor beside the task; with ``action = "abort"`` the run ends and the actuators are brought to a
protective stop in the tick the guard sees the force (before that tick's physics step), with ``action =
"recover"`` a named recovery takes over::

    [sensors.touch]
    type = "contact"
    body = "panda"
    other = "table"

    [monitors.guard]
    type = "guard"
    sensor = "touch"            # a contact sensor (normal force) or a force_torque sensor (force magnitude)
    max_force = 20.0            # N; 0 with a contact sensor = any contact
    action = "abort"

Readings in, an outcome out: it never commands anything.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs import ContactState, Wrench


class GuardConfig(Schema):
    """``[monitors.NAME]`` with ``type = "guard"``."""

    sensor: str = Field(description="a contact sensor or a force_torque sensor")
    max_force: float = Field(0.0, ge=0, description="N: contact normal force, or wrench force magnitude, above "
                             "which the guard trips")
    baseline: bool = Field(True, description="force_torque: measure from the first reading (the tool's own weight "
                           "is not a collision)")


class Guard(Behaviour):
    """Trips (``aborted``, with the force, what was touched and when) when a force limit is crossed."""
    COMMANDS: ClassVar[tuple[str, ...]] = ()

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        comp = ctx.components.get(self.config.sensor)
        kind = getattr(comp, "reading_type", None)
        if kind not in (ContactState, Wrench):
            found = [n for n, c in ctx.components.items() if getattr(c, "reading_type", None) in (ContactState,
                                                                                                  Wrench)]
            raise ConfigError(f"{self.config.sensor!r} is not a contact or force_torque sensor; those: "
                              f"{', '.join(found) or '(none)'}", key="sensor")
        self.zero: tuple[float, float, float] | None = None
        self.peak = 0.0
        self.tripped_at: float | None = None
        self.held: float | None = None
        """While watching a recovery: the force that tripped the guard, until the force is back within the limit."""

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        reading = readings[self.config.sensor]
        if isinstance(reading, Wrench):
            force, what = self._wrench_force(reading), f"force {self._wrench_force(reading):.1f} N at {reading.frame}"
            touching = force > self.config.max_force
        else:
            force, what = reading.normal_force, f"contact with {', '.join(reading.others) or 'something'} " \
                                                f"({reading.normal_force:.1f} N)"
            touching = reading.in_contact and force > self.config.max_force
        self.peak = max(self.peak, force)
        limit = self.config.max_force
        if self.held is not None and force > limit:  # the stop has not relieved the force yet: no worse than that
            limit = self.held + self.config.max_force
            touching = touching and force > limit
        elif self.held is not None:
            self.held = None  # relieved: the limit holds again
        if touching:
            self.tripped_at = t
            self.finish("aborted", f"{what} at t = {t:.3f} s (limit {limit:g} N)")
        return None

    def can_succeed(self) -> bool:
        """A guard never succeeds: it trips (``aborted``) or watches until the run ends."""
        return False

    def take_over(self, previous: Guard) -> None:
        """Watch on after ``previous`` tripped (a recovery runs): measure from its force baseline; until the force
        is back within ``max_force``, trip only above the force that tripped it plus ``max_force`` (the recovery may
        relieve the contact, not press harder)."""
        self.zero = previous.zero
        self.held = previous.peak

    def _wrench_force(self, w: Wrench) -> float:
        if self.config.baseline and self.zero is None:
            self.zero = w.force
        zx, zy, zz = self.zero or (0.0, 0.0, 0.0)
        fx, fy, fz = w.force
        return float(((fx - zx) ** 2 + (fy - zy) ** 2 + (fz - zz) ** 2) ** 0.5)

    def result(self) -> dict[str, Any]:
        return {"peak_force": round(self.peak, 3), "tripped_at": self.tripped_at}


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("guard", Guard, GuardConfig)
