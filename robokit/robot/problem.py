"""A problem the robot checks report (:class:`Problem`), and which robots are mobile bases."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robokit.robot.model import Robot


@dataclass(frozen=True)
class Problem:
    """One problem: which ``check`` found it, the element (``link 'x'`` / ``joint 'y'``), what and how to fix it."""

    check: str
    where: str
    message: str
    fix: str
    line: int = 0
    warning: bool = False
    """A warning is shown by ``robokit robot check`` but refuses nothing: inertias out of scale with the link's
    size (PyBullet's own Panda and R2D2 carry placeholder inertias of 0.3 and 1 kg·m² on small links)."""

    def text(self, file: str | Path) -> str:
        """``FILE[:LINE]: [warning: ]ELEMENT: PROBLEM; fix: FIX [check]`` on one line."""
        at = f"{file}:{self.line}" if self.line else str(file)
        kind = "warning: " if self.warning else ""
        return f"{at}: {kind}{self.where}: {self.message}; fix: {self.fix} [{self.check}]"


def is_mobile(robot: Robot, fixed_base: bool | None) -> bool:
    """A mobile base: not fixed in place, with at least two wheels (continuous joints whose child collides)."""
    return fixed_base is not True and len(robot.wheels()) >= 2
