"""The GUI window (PyBullet's, or MuJoCo's viewer), made helpful: a display check with a clear error, the ``[gui]``
viewpoint, and holding the window.

Only ``--gui`` runs use this; nothing here runs in headless worlds. ``time.sleep`` appears here only to pace the
window while it is held open after a run (GUI pacing, never logic).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

from robokit.errors import UserError


def check_display(command: str = "robokit run CONFIG --gui") -> None:
    """Fail at once, in one line, when a GUI is asked for on a machine with no display (Linux/BSD: no ``DISPLAY``).

    Raises:
        UserError: No display; the message suggests running headless or under ``xvfb-run``.
    """
    if sys.platform.startswith(("linux", "freebsd", "openbsd")) and not os.environ.get("DISPLAY") \
            and not os.environ.get("WAYLAND_DISPLAY"):
        raise UserError(f"no display (DISPLAY is not set) for --gui: run without --gui (headless), or under a "
                        f"virtual display: xvfb-run -a {command}")


def scene_centre(world: Any) -> tuple[float, float, float]:
    """Centre of the bounding box of every body smaller than 5 m across (ground planes and arena floors excluded)."""
    los, his = [], []
    for name in world.body_names:
        lo, hi = world.body_aabb(name)
        if max(h - low for h, low in zip(hi, lo, strict=True)) < 5.0:
            los.append(lo)
            his.append(hi)
    if not los:
        return (0.0, 0.0, 0.0)
    lo = [min(b[i] for b in los) for i in range(3)]
    hi = [max(b[i] for b in his) for i in range(3)]
    return ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, max(0.0, (lo[2] + hi[2]) / 2))


def apply_view(world: Any, gui: Any) -> None:
    """Set the GUI camera (``distance``, ``yaw``, ``pitch``, ``target``) and panels from a ``[gui]`` config."""
    window = getattr(world, "window", None)
    if window is not None:  # the mujoco engine's viewer: its camera (it has no panels or shadow switch to set)
        target = list(gui.target) if gui.target is not None else list(scene_centre(world))
        window.look(gui.distance, gui.yaw, gui.pitch, target)
        return
    import pybullet as p

    client = world.client
    target = list(gui.target) if gui.target is not None else list(scene_centre(world))
    client.configureDebugVisualizer(p.COV_ENABLE_GUI, 1 if gui.panels else 0)
    if gui.shadows is not None:
        client.configureDebugVisualizer(p.COV_ENABLE_SHADOWS, 1 if gui.shadows else 0)
    client.resetDebugVisualizerCamera(cameraDistance=gui.distance, cameraYaw=gui.yaw, cameraPitch=gui.pitch,
                                      cameraTargetPosition=target)


def hold(world: Any, *, fps: float = 30.0) -> None:
    """Keep the GUI window open (the scene frozen as the run left it) until it is closed or Ctrl-C is pressed."""
    client = world.client
    window = getattr(world, "window", None)
    try:  # the message inside: a Ctrl-C the moment it appears (before the loop starts) only ends the hold too
        print("robokit: the run is over; the window stays open until you close it (or press Ctrl-C)",
              file=sys.stderr, flush=True)
        while window.is_open() if window is not None else client is not None and client.isConnected():
            if window is None:  # PyBullet's window (MuJoCo's viewer draws in its own thread)
                client.getDebugVisualizerCamera()  # keeps the window responsive (camera moves, redraws)
            time.sleep(1.0 / fps)  # GUI pacing only
    except KeyboardInterrupt:
        return
    except Exception:  # noqa: BLE001 - the window was closed under us: that is how holding ends
        return
