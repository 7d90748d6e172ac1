"""Camera images on the mujoco engine: MuJoCo's OpenGL renderer (headless through EGL: ``MUJOCO_GL=egl``, set by
robokit when nothing else is) drawn from the World's OpenGL view and projection matrices.

Depth comes back in metres along the view axis (MuJoCo linearises its depth buffer with the near and far planes,
which are set from the camera's for each frame); segmentation is the robokit body id per pixel (-1: background).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from robokit.engines.interface import RenderedImage
from robokit.engines.mujoco.gl import mujoco
from robokit.errors import UserError

if TYPE_CHECKING:
    from robokit.engines.mujoco.bodies import MujocoBodies


class Cameras:
    """One MuJoCo renderer per image size, made on first use and closed with the world (or its owner).

    ``what`` and ``hint`` make the one line said when no OpenGL context can be made."""

    def __init__(self, what: str = "camera",
                 hint: str = "set MUJOCO_GL=egl (or osmesa) before anything imports mujoco") -> None:
        self.renderers: dict[tuple[int, int], Any] = {}
        self.what, self.hint = what, hint

    def get(self, model: Any, width: int, height: int) -> Any:
        key = (width, height)
        renderer = self.renderers.get(key)
        if renderer is None or renderer.model is not model:
            if renderer is not None:
                renderer.close()
            model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
            model.vis.global_.offheight = max(model.vis.global_.offheight, height)
            try:
                renderer = self.renderers[key] = mujoco.Renderer(model, height, width)
            except Exception as exc:  # noqa: BLE001 - MuJoCo's FatalError when no OpenGL context can be made
                raise UserError(f"{self.what}: MuJoCo could not render ({str(exc).splitlines()[0][:120]}); "
                                f"{self.hint}") from None
        return renderer

    def close(self) -> None:
        for renderer in self.renderers.values():
            renderer.close()
        self.renderers.clear()


def _place(renderer: Any, data: Any, view: Sequence[float], projection: Sequence[float], near: float,
           far: float) -> None:
    """Update the scene and put its camera where the OpenGL matrices (column-major) say."""
    renderer.update_scene(data)
    v = np.asarray(view, dtype=float).reshape(4, 4).T
    p = np.asarray(projection, dtype=float).reshape(4, 4).T
    rot, trans = v[:3, :3], v[:3, 3]
    half_h, half_w = near / p[1, 1], near / p[0, 0]
    for cam in renderer.scene.camera:
        cam.pos = -rot.T @ trans
        cam.forward = -rot[2]
        cam.up = rot[1]
        cam.frustum_center = 0.0
        cam.frustum_width = half_w
        cam.frustum_bottom, cam.frustum_top = -half_h, half_h
        cam.frustum_near, cam.frustum_far = near, far
        cam.orthographic = 0


def _aimed(world: MujocoBodies, cameras: Cameras, width: int, height: int, view: Sequence[float],
           projection: Sequence[float], near: float, far: float) -> tuple[Any, Any, Any]:
    """The model, data and a renderer of ``width`` x ``height`` with the scene updated and the camera placed."""
    model, data = world.compiled()
    renderer = cameras.get(model, width, height)
    extent = float(model.stat.extent)
    model.vis.map.znear, model.vis.map.zfar = near / extent, far / extent
    _place(renderer, data, view, projection, near, far)
    return model, data, renderer


def colour(world: MujocoBodies, cameras: Cameras, width: int, height: int, view: Sequence[float],
           projection: Sequence[float], *, near: float, far: float) -> np.ndarray:
    """RGB only (height, width, 3), uint8: what a video frame needs."""
    _, _, renderer = _aimed(world, cameras, width, height, view, projection, near, far)
    return renderer.render().copy()  # type: ignore[no-any-return]


def render(world: MujocoBodies, cameras: Cameras, width: int, height: int, view: Sequence[float],
           projection: Sequence[float], *, near: float, far: float, segmentation: bool = True) -> RenderedImage:
    """RGB, depth (m) and segmentation (body ids) of one camera."""
    model, data, renderer = _aimed(world, cameras, width, height, view, projection, near, far)
    rgb = renderer.render().copy()
    renderer.enable_depth_rendering()
    _place(renderer, data, view, projection, near, far)
    depth = np.clip(renderer.render(), near, far).astype(np.float32)
    renderer.disable_depth_rendering()
    mask = None
    if segmentation:
        renderer.enable_segmentation_rendering()
        _place(renderer, data, view, projection, near, far)
        seg = renderer.render()
        renderer.disable_segmentation_rendering()
        owners = world.owners()
        lookup = np.full(model.ngeom + 1, -1, dtype=np.int32)
        for g in range(model.ngeom):
            lookup[g] = owners.get(int(model.geom_bodyid[g]), (-1, -1))[0]
        is_geom = seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
        mask = np.where(is_geom, lookup[np.where(is_geom, seg[..., 0], model.ngeom)], -1).astype(np.int32)
    return RenderedImage(rgb, depth, mask)
