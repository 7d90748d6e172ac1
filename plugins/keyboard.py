"""``keyboard`` sensor: keys held in the engine's viewer (lessons 03 and 07), or a timed script when headless.

In GUI mode it reads the World's key events (:meth:`World.key_events <robokit.engines.interface.World.key_events>`).
A ``script`` of timed key presses makes the same teleop configs run headless and deterministic (tests, demos): each
entry holds ``keys`` down from ``at`` for ``hold`` sim seconds.
Under ``robokit run --live`` the keys held in the live page count too (as a window's; ``docs/live.md``).

A key tapped between two readings (pressed and released before the sensor was due again) is not lost: the World
flags it ``KEY_TRIGGERED`` without ``KEY_DOWN``, and the reading lists it in ``pressed`` (not in ``down``).
A scripted press shorter than the sensor's period behaves the same way.
"""

from __future__ import annotations

import string
from collections.abc import Mapping
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.engines.interface import KEY_DOWN, KEY_DOWN_ARROW, KEY_LEFT, KEY_RETURN, KEY_RIGHT, KEY_TRIGGERED, KEY_UP
from robokit.errors import ConfigError
from robokit.msgs.keyboard import KeyState

SPECIAL = {
    KEY_UP: "up",
    KEY_DOWN_ARROW: "down",
    KEY_LEFT: "left",
    KEY_RIGHT: "right",
    KEY_RETURN: "return",
    ord(" "): "space",
}
KEY_NAMES = {**SPECIAL, **{ord(c): c for c in string.digits + string.ascii_lowercase}}
VALID = frozenset(KEY_NAMES.values())


class KeyPress(Schema):
    """One scripted press: ``keys`` held from ``at`` for ``hold`` sim seconds."""

    at: float = Field(ge=0)
    keys: tuple[str, ...]
    hold: float = Field(0.1, gt=0)


class KeyboardConfig(Schema):
    """``script``: timed key presses used when there is no GUI (or always, with ``script_in_gui``)."""

    script: tuple[KeyPress, ...] = ()
    script_in_gui: bool = False


class KeyboardSensor(Sensor):
    """Keys held down in the GUI, or replayed from a timed script when headless."""

    reading_type = KeyState
    lazy = False  # "pressed since the last reading" needs every due tick observed
    example = {"config": {"script": [{"at": 0.05, "keys": ["up", "1"], "hold": 0.05}]}}

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        script = self.config.script if self.config else ()
        for i, press in enumerate(script):
            bad = [k for k in press.keys if k not in VALID]
            if bad:
                raise ConfigError(f"unknown key {bad[0]!r}; valid: {', '.join(sorted(VALID))}",
                                  key=f"script[{i}].keys")
        self.use_gui = self.world.gui and not (self.config and self.config.script_in_gui)
        self.previous: frozenset[str] = frozenset()
        self.key_source: Any = None
        """Keys from a live page (``robokit run --live``): its ``key_events()``, read beside the script."""
        self.last_read = -1.0

    def _scripted(self) -> tuple[frozenset[str], frozenset[str]]:
        """Keys held now, and keys whose press began since the last reading (even if already released)."""
        t = self.world.time
        held: set[str] = set()
        began: set[str] = set()
        for press in self.config.script if self.config else ():
            if press.at <= t < press.at + press.hold:
                held.update(press.keys)
            if self.last_read < press.at <= t:
                began.update(press.keys)
        self.last_read = t
        return frozenset(held), frozenset(began)

    def read(self) -> KeyState:
        if self.use_gui:
            state = decode_events(self.world.key_events(), self.previous)
        else:
            down, began = self._scripted()
            if self.key_source is not None:  # keys held in the live page, as a window's
                page = decode_events(self.key_source.key_events(), self.previous)
                down, began = down | page.down, began | page.pressed
            state = KeyState(down=down, pressed=(down - self.previous) | began)
        self.previous = state.down
        return state


def decode_events(events: Mapping[int, int], previous: frozenset[str]) -> KeyState:
    """A :class:`KeyState` from the World's ``key_events()`` (key code -> state flags since the last call; PyBullet's
    ``getKeyboardEvents()`` codes and flags).

    ``down``: keys flagged ``KEY_DOWN``. ``pressed``: keys flagged ``KEY_TRIGGERED`` (also a tap released
    before this call) plus keys down now that were not down at the previous reading.
    """
    down = frozenset(KEY_NAMES[k] for k, flags in events.items() if k in KEY_NAMES and flags & KEY_DOWN)
    triggered = frozenset(KEY_NAMES[k] for k, flags in events.items()
                          if k in KEY_NAMES and flags & KEY_TRIGGERED)
    return KeyState(down=down, pressed=triggered | (down - previous))


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("keyboard", KeyboardSensor, KeyboardConfig)
