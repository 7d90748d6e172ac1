"""Reading of the ``keyboard`` sensor, free of pybullet (teleop behaviours import it)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "KeyState",
]


@dataclass(frozen=True)
class KeyState:
    """Keys held down now, and keys pressed since the previous reading.

    Key names: ``"up"``, ``"down"``, ``"left"``, ``"right"``, ``"space"``, ``"return"``, digits ``"0"``–``"9"``
    and lower-case letters ``"a"``–``"z"``.
    """

    down: frozenset[str] = frozenset()
    pressed: frozenset[str] = frozenset()
