"""A recorded scene drawn by MuJoCo: the frames of ``robokit video`` (and its stills) for a run that ran on MuJoCo.

The scene is the run's own MuJoCo model, rebuilt from the record (:func:`robokit.record.scene.rebuild` with
``engine="mujoco"``) and posed from the pose log through the World; this draws it with ``mujoco.Renderer``
(OpenGL, headless through EGL: :mod:`robokit.engines.mujoco.gl`), colour only, through the camera the PyBullet
path uses (the same view and projection matrices, near and far planes). What it shows is what the run's MuJoCo
cameras saw: the model's geoms, colours and lights.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from robokit.engines.mujoco.gl import mujoco
from robokit.engines.mujoco.render import Cameras, colour

NEAR, FAR = 0.02, 50.0
"""Near and far planes (m), as the PyBullet video's."""


def problem() -> str | None:
    """Why MuJoCo cannot draw here (no OpenGL context: no EGL, a bad ``MUJOCO_GL``), or None: it can."""
    try:
        renderer = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8)
    except Exception as exc:  # noqa: BLE001 - MuJoCo's FatalError (or an OpenGL error) when no context can be made
        return str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
    renderer.close()
    return None


class SceneRenderer:
    """Draws one rebuilt MuJoCo world through one camera at one size (the camera sensors' renderer cache: a
    recompiled model gets a new renderer).

    ``view_matrix`` and ``projection`` are OpenGL's (16 floats, column-major), as the PyBullet renderer's.
    """

    def __init__(self, world: Any, view_matrix: Any, projection: Any, size: tuple[int, int]) -> None:
        self.world, self.view_matrix, self.projection, self.size = world, view_matrix, projection, size
        self.cameras = Cameras("video", "draw it with --renderer pybullet, or set MUJOCO_GL=egl (or osmesa)")

    def render(self) -> np.ndarray:
        """The world as posed now, RGB (height, width, 3) uint8."""
        w, h = self.size
        return colour(self.world, self.cameras, w, h, self.view_matrix, self.projection, near=NEAR, far=FAR)

    def close(self) -> None:
        self.cameras.close()
