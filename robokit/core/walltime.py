"""Wall time per component, measured only when a wall-clock budget is set (``--max-wall``, ``max_wall_time``).

While a budget is set, every sensor, actuator and the behaviour is wrapped in a :class:`_Timed` proxy that adds
the wall time of each ``read``/``update``/``command``/``step`` call to its component's total (its own time: a
sensor read lazily from inside the behaviour's step counts for the sensor, not the behaviour). Without a budget
nothing is wrapped and the loop pays nothing. When the budget runs out, :meth:`WallTiming.slowest` names the
component that took the most (and the one that was running when the watchdog stopped the run).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_METHODS = ("read", "update", "command", "step")


class _Timed:
    """Stands in for a component in the loop: forwards everything, timing the per-tick methods."""

    def __init__(self, target: Any, label: str, timing: WallTiming) -> None:
        self._target = target
        self._label = label
        self._timing = timing
        for name in _METHODS:
            if hasattr(target, name):
                setattr(self, name, self._wrap(getattr(target, name)))

    def _wrap(self, method: Callable[..., Any]) -> Callable[..., Any]:
        timing, label, clock = self._timing, self._label, self._timing.clock

        def timed(*args: Any) -> Any:
            frame: list[Any] = [label, clock(), 0.0]  # label, start, time in components called from inside it
            timing.stack.append(frame)
            try:
                result = method(*args)
            except BaseException:
                if timing.stopped_in is None:
                    timing.stopped_in = label  # innermost first: the component that was running
                raise
            finally:
                timing.stack.pop()
                elapsed = clock() - float(frame[1])
                timing.spent[label] = timing.spent.get(label, 0.0) + elapsed - float(frame[2])
                timing.calls[label] = timing.calls.get(label, 0) + 1
                if timing.stack:
                    timing.stack[-1][2] = float(timing.stack[-1][2]) + elapsed
            return result

        return timed

    def __getattr__(self, name: str) -> Any:
        return getattr(self._target, name)


class WallTiming:
    """Wraps a scheduler's components for the duration of a run; :meth:`restore` unwraps them."""

    def __init__(self, scheduler: Any, clock: Callable[[], float]) -> None:
        self.clock = clock
        self.spent: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self.stack: list[list[Any]] = []
        self.stopped_in: str | None = None
        """The innermost component that was running when an exception (e.g. the watchdog's) broke out."""
        self._scheduler = scheduler
        self._slots = list(scheduler.slots.values())
        self._behaviour = scheduler.behaviour
        for slot in self._slots:
            slot.component = _Timed(slot.component, f"{slot.component.kind} {slot.name!r} ({slot.origin})", self)
        if self._behaviour is not None:
            scheduler.behaviour = _Timed(self._behaviour, f"behaviour ({scheduler.behaviour_origin})", self)

    def restore(self) -> None:
        """Put the real components back."""
        for slot in self._slots:
            if isinstance(slot.component, _Timed):
                slot.component = slot.component._target
        self._scheduler.behaviour = self._behaviour

    def slowest(self) -> str:
        """``"sensor 'x' (type ... from ...) 9.8 s in 2 calls"`` for the component with the most wall time."""
        if not self.spent:
            return ""
        label = max(self.spent, key=lambda k: self.spent[k])
        text = f"{label} {self.spent[label]:.2f} s in {self.calls.get(label, 0)} call(s)"
        if self.stopped_in is not None:
            text += f" (stopped inside {'it' if self.stopped_in == label else self.stopped_in})"
        return text
