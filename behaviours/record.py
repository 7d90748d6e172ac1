"""``record`` behaviour: write sensor (and actuator) readings into the run's trace, for a while, then succeed.

The simplest way to see what a sensor measures — in particular a third-party sensor — without writing a
behaviour::

    [sensors.imu]
    type = "imu"
    body = "box"

    [behaviour]
    type = "record"
    rate_hz = 60          # record 60 times per sim second (default: every tick)
    duration = 1.0        # sim seconds, then the run succeeds

    $ robokit run imu.toml --trace trace.jsonl

Every step appends one trace record per component: ``{"kind": "reading", "component": "imu", "value": {...}}``
(dataclasses become dicts, numpy arrays lists; arrays larger than ``max_array`` items are summarised by shape and
dtype, so camera frames do not flood the trace). The result holds the number of readings recorded per component
and the last one of each.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import Field

from robokit import hookimpl
from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError


class RecordConfig(Schema):
    """``components``: names to record (empty = every sensor); ``duration``: sim seconds (0: until the run ends);
    ``max_array``: arrays with more items are summarised."""

    components: tuple[str, ...] = ()
    duration: float = Field(1.0, ge=0, description="sim seconds to record, then succeed; 0 = until the run ends "
                                                   "(as a monitor: until the task ends)")
    max_array: int = Field(64, ge=0)


def to_jsonable(value: Any, max_array: int = 64) -> Any:
    """A JSON-safe copy of a reading: dataclasses as dicts, tuples as lists, arrays as lists (or a summary),
    non-finite floats as None."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: to_jsonable(getattr(value, f.name), max_array) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v, max_array) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v, max_array) for v in value]
    if isinstance(value, (set, frozenset)):
        return sorted((to_jsonable(v, max_array) for v in value), key=repr)
    if hasattr(value, "tolist") and hasattr(value, "shape"):
        if getattr(value, "size", 0) > max_array:
            return {"shape": list(value.shape), "dtype": str(value.dtype)}
        return to_jsonable(value.tolist(), max_array)
    if hasattr(value, "item"):  # numpy scalar
        return to_jsonable(value.item(), max_array)
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (str, int, bool)):
        return value
    return str(value)


class Record(Behaviour):
    """Writes readings of named sensors/actuators into the trace at its rate, then succeeds after `duration`."""
    COMMANDS: ClassVar[tuple[str, ...]] = ()

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        names = self.config.components
        for i, name in enumerate(names):
            if name not in ctx.components:
                raise ConfigError(str(LookupNameError("sensor or actuator", name, ctx.components)),
                                  key=f"components[{i}]")
        sensors = [n for n, c in ctx.components.items() if getattr(c, "kind", "") == "sensor"]
        self.names: tuple[str, ...] = names or tuple(sensors)
        self.counts: dict[str, int] = {name: 0 for name in self.names}
        self.last: dict[str, Any] = {}

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        for name in self.names:
            value = to_jsonable(readings[name], self.config.max_array)
            self.ctx.trace("reading", component=name, value=value)
            self.counts[name] += 1
            self.last[name] = value
        if 0 < self.config.duration <= self.elapsed(t):
            self.finish("succeeded", f"recorded {sum(self.counts.values())} readings in {self.elapsed(t):g} s")
        return None

    def can_succeed(self) -> bool:
        """With ``duration = 0`` it records until the run ends and never succeeds."""
        return bool(self.config.duration > 0)

    def result(self) -> dict[str, Any]:
        return {"recorded": dict(self.counts), "last": dict(self.last)}


@hookimpl
def robokit_register_behaviours(register):  # type: ignore[no-untyped-def]
    register("record", Record, RecordConfig)
