"""``keyboard`` sensor: keys held in the PyBullet GUI (lessons 03 and 07), or a timed script when headless.

In GUI mode it reads ``getKeyboardEvents`` of the World's own client. A ``script`` of timed key presses makes the
same teleop configs run headless and deterministic (tests, demos): each entry holds ``keys`` down from ``at`` for
``hold`` sim seconds.
"""

from __future__ import annotations

import string

import pybullet as p
from pydantic import Field

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError
from robokit.msgs.keyboard import KeyState

SPECIAL = {
    p.B3G_UP_ARROW: "up",
    p.B3G_DOWN_ARROW: "down",
    p.B3G_LEFT_ARROW: "left",
    p.B3G_RIGHT_ARROW: "right",
    p.B3G_RETURN: "return",
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

    def _scripted(self) -> frozenset[str]:
        t = self.world.time
        held: set[str] = set()
        for press in self.config.script if self.config else ():
            if press.at <= t < press.at + press.hold:
                held.update(press.keys)
        return frozenset(held)

    def _gui(self) -> frozenset[str]:
        events = self.world.client.getKeyboardEvents()
        return frozenset(KEY_NAMES[k] for k, state in events.items() if k in KEY_NAMES and state & p.KEY_IS_DOWN)

    def read(self) -> KeyState:
        down = self._gui() if self.use_gui else self._scripted()
        state = KeyState(down=down, pressed=down - self.previous)
        self.previous = down
        return state


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("keyboard", KeyboardSensor, KeyboardConfig)
