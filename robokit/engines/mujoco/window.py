"""The GUI window of the mujoco engine: MuJoCo's own passive viewer, showing the world's model and data.

``World(gui=True)`` on MuJoCo opens it at the first compile and shows every step (``sync``) while robokit steps the
physics itself; a recompile (a body added, removed, or a static body moved for the first time) opens it again on the
new model. The viewer draws in a thread of its own: closing joins that thread, so that the process never ends while
it still holds the OpenGL context (MuJoCo's viewer crashes the interpreter's exit otherwise).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

AZIMUTH_OF_YAW = 90.0
"""MuJoCo's azimuth for PyBullet's camera yaw 0: robokit's ``[gui] yaw`` turns the same way on both engines."""


class Window:
    """One passive viewer at a time, on the model it was opened on."""

    def __init__(self) -> None:
        self.handle: Any = None
        self._threads: list[threading.Thread] = []
        self._model: Any = None
        self.closed_by_user = False
        """The person closed the window (the run goes on headless; a held window ends)."""
        self._view: tuple[float, float, float, Sequence[float] | None] | None = None

    def show(self, model: Any, data: Any) -> None:
        """Open on ``model`` / ``data`` (again, if the model is a new one)."""
        if self.closed_by_user or model is self._model:
            return
        self._close_viewer()
        import mujoco.viewer

        before = set(threading.enumerate())
        self.handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
        self._threads = [t for t in threading.enumerate() if t not in before]
        self._model = model
        if self._view is not None:
            self.look(*self._view)

    def sync(self) -> None:
        """Draw the data as it is now (the viewer copies it under its lock)."""
        handle = self.handle
        if handle is None:
            return
        if handle.is_running():
            handle.sync()
        else:
            self.closed_by_user = True
            self._close_viewer()

    def look(self, distance: float, yaw: float, pitch: float, target: Sequence[float] | None) -> None:
        """Point the camera as ``[gui]`` says (PyBullet's yaw and pitch, in degrees; ``target`` None: keep)."""
        self._view = (distance, yaw, pitch, target)
        if self.handle is None:
            return
        with self.handle.lock():
            cam = self.handle.cam
            cam.distance, cam.azimuth, cam.elevation = distance, yaw + AZIMUTH_OF_YAW, pitch
            if target is not None:
                cam.lookat[:] = list(target)

    def is_open(self) -> bool:
        return self.handle is not None and bool(self.handle.is_running())

    def close(self) -> None:
        """Close the viewer and wait for its thread. Safe to call twice. (GLFW stays connected to the display for
        the next window of the process: MuJoCo's viewer cannot start GLFW again once it was terminated.)"""
        self._close_viewer()
        self._model = None

    def _close_viewer(self) -> None:
        if self.handle is not None:
            self.handle.close()
            self.handle = None
        for thread in self._threads:
            thread.join(timeout=10.0)
        self._threads = []
