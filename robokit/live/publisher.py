"""What the loop and the live server share: a one-slot buffer of the latest state, the run's controls (pause, step,
speed) and the keys held in the page.

The loop only ever puts into these and never waits for a reader: a page that is slow, or gone, misses frames, never
ticks. The server's threads take the latest frame (waiting for a newer one if they have seen it) and set controls and
keys; the loop reads those at a tick boundary.
"""

from __future__ import annotations

import math
import string
import threading
import time
from collections.abc import Callable
from typing import Any

from robokit.engines.interface import (
    KEY_DOWN,
    KEY_DOWN_ARROW,
    KEY_LEFT,
    KEY_RETURN,
    KEY_RIGHT,
    KEY_TRIGGERED,
    KEY_UP,
)

SPEEDS = {"1": 1.0, "2": 2.0, "max": math.inf}
"""The speeds the page offers: sim seconds per wall second (``max``: as fast as the machine goes)."""

KEY_CODES = {"up": KEY_UP, "down": KEY_DOWN_ARROW, "left": KEY_LEFT, "right": KEY_RIGHT, "return": KEY_RETURN,
             "space": ord(" "), **{c: ord(c) for c in string.digits + string.ascii_lowercase}}
"""Key names the page sends, to the codes the World's ``key_events()`` uses (PyBullet's)."""


class Publisher:
    """A one-slot buffer: :meth:`put` replaces the latest frame (never blocks for long); :meth:`take` waits for a
    frame newer than the one a reader has seen."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._frame: dict[str, Any] | None = None
        self.seq = 0
        """How many frames were put so far (the latest frame's number)."""
        self.closed = False

    def put(self, frame: dict[str, Any]) -> None:
        with self._cond:
            self.seq += 1
            self._frame = {**frame, "seq": self.seq}
            self._cond.notify_all()

    def latest(self) -> dict[str, Any] | None:
        with self._cond:
            return self._frame

    def take(self, seen: int, timeout: float) -> dict[str, Any] | None:
        """The latest frame once it is newer than frame number ``seen``; None after ``timeout`` s or when closed."""
        with self._cond:
            self._cond.wait_for(lambda: self.seq > seen or self.closed, timeout)
            return self._frame if self.seq > seen else None

    def close(self) -> None:
        with self._cond:
            self.closed = True
            self._cond.notify_all()


class Control:
    """Pause, single steps and speed, set from the page, obeyed by the loop at tick boundaries (:meth:`gate`).

    Pacing only ever waits: the ticks a run takes and their order are the same at any speed, paused or not.
    """

    def __init__(self, *, paused: bool = False, speed: float = 1.0,
                 wall_clock: Callable[[], float] = time.perf_counter) -> None:
        self._cond = threading.Condition()
        self.paused = paused
        self.speed = speed
        self._steps = 0
        self._clock = wall_clock
        self._anchor: tuple[float, float] | None = None  # (wall s, sim s) pacing counts from

    def state(self) -> dict[str, Any]:
        with self._cond:
            return {"paused": self.paused, "speed": "max" if math.isinf(self.speed) else self.speed}

    def apply(self, action: str, value: str = "") -> None:
        """``pause``, ``resume``, ``step`` (``value`` ticks, one if empty, pausing first), or ``speed`` with
        ``value`` one of :data:`SPEEDS`.

        Raises:
            ValueError: An unknown action or speed.
        """
        with self._cond:
            if action == "pause":
                self.paused = True
            elif action == "resume":
                self.paused, self._steps, self._anchor = False, 0, None
            elif action == "step":
                count = int(value) if value.isdigit() else 0 if value else 1
                if count < 1:
                    raise ValueError(f"step takes a whole number of ticks (1 or more), not {value!r}")
                self.paused = True
                self._steps += count
            elif action == "speed":
                if value not in SPEEDS:
                    raise ValueError(f"unknown speed {value!r}; choose one of {', '.join(SPEEDS)}")
                self.speed, self._anchor = SPEEDS[value], None
            else:
                raise ValueError(f"unknown action {action!r}; choose one of pause, resume, step, speed")
            self._cond.notify_all()

    def gate(self, sim_time: float, stopped: Callable[[], bool], on_hold: Callable[[], None]) -> None:
        """Called by the loop before a tick at ``sim_time``: wait while paused (``on_hold`` is called once, so the
        page sees the scene it is held at) until a step or resume, then wait until wall time catches up with sim
        time at the chosen speed. Returns at once when ``stopped()`` (Ctrl-C)."""
        held = False
        with self._cond:
            while not stopped():
                if self.paused:
                    if self._steps:
                        self._steps -= 1
                        self._anchor = None
                        return
                    if not held:  # once per hold: the page is shown the scene it is held at
                        held = True
                        self._cond.release()
                        try:
                            on_hold()
                        finally:
                            self._cond.acquire()
                        continue
                    self._cond.wait(0.2)
                    continue
                if math.isinf(self.speed):
                    return
                now = self._clock()
                if self._anchor is None:
                    self._anchor = (now, sim_time)
                ahead = (sim_time - self._anchor[1]) / self.speed - (now - self._anchor[0])
                if ahead <= 0:
                    return
                self._cond.wait(min(ahead, 0.2))  # real-time pacing only: a control change wakes it


class PageKeys:
    """Keys held in the page, as the World's ``key_events()`` reports a window's: code -> ``KEY_DOWN`` and/or
    ``KEY_TRIGGERED`` (pressed since the last call, even if released since)."""

    def __init__(self) -> None:
        self._lock = threading.Condition()
        self._down: set[int] = set()
        self._triggered: set[int] = set()

    def press(self, name: str, down: bool) -> None:
        """A key pressed (``down``) or released in the page.

        Raises:
            ValueError: A key the keyboard sensor does not know.
        """
        code = KEY_CODES.get(name)
        if code is None:
            raise ValueError(f"unknown key {name!r}")
        with self._lock:
            if down:
                if code not in self._down:
                    self._triggered.add(code)
                self._down.add(code)
            else:
                self._down.discard(code)
            self._lock.notify_all()

    def wait_held(self, names: set[str], timeout: float) -> bool:
        """Wait until exactly the keys ``names`` are held in the page; False after ``timeout`` s."""
        codes = {KEY_CODES[n] for n in names}
        with self._lock:
            return self._lock.wait_for(lambda: self._down == codes, timeout)

    def key_events(self) -> dict[int, int]:
        with self._lock:
            events = {code: KEY_DOWN for code in self._down}
            for code in self._triggered:
                events[code] = events.get(code, 0) | KEY_TRIGGERED
            self._triggered.clear()
            return events
