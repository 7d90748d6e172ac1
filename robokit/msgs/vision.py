"""Readings of the vision plugins (``camera``, ``colour_detector``), free of PyBullet.

Behaviours import these to read camera frames and colour detections without importing pybullet.

Frames and conventions:

* Pixels: ``(u, v)`` = (column, row), origin top-left, ``u`` to the right, ``v`` down. Where inside a pixel the
  renderer samples is the frame's ``sample_offset``: 0.5 = the pixel centre (OpenGL); PyBullet's TinyRenderer
  samples at the pixel's corner in OpenGL's bottom-up rows, i.e. ``x_ndc = 2u/W - 1``, ``y_ndc = 1 - 2(v+1)/H``
  (offset 0.0; measured: using the centre there biases positions by half a pixel).
* View and projection matrices are kept exactly as PyBullet takes them (16 floats, column-major, OpenGL
  convention: the camera looks along its -z axis). :func:`deproject` inverts them.
* Depth is metric: the distance in metres along the camera's optical axis (eye-space ``-z``), not along the ray.
* World positions are metres, world frame ``(x, y, z)``; yaw is radians about world +z.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "Vec3",
    "Matrix16",
    "gl_matrix",
    "deproject",
    "CameraFrame",
    "Detection",
    "Detections",
]

Vec3 = tuple[float, float, float]
Matrix16 = tuple[float, ...]


def gl_matrix(values: Matrix16) -> np.ndarray:
    """A PyBullet 16-float column-major matrix as a row-major 4x4 numpy array."""
    return np.asarray(values, dtype=float).reshape(4, 4).T


def deproject(
    us: np.ndarray, vs: np.ndarray, depth_m: np.ndarray, view: Matrix16, projection: Matrix16,
    width: int, height: int, sample_offset: float = 0.5,
) -> np.ndarray:
    """World points (N x 3, metres) of pixels ``(us, vs)`` whose metric depths are ``depth_m``.

    Args:
        us: Pixel columns (N,); the pixel centre is used.
        vs: Pixel rows (N,).
        depth_m: Depth in metres along the optical axis at each pixel (N,).
        view: The frame's view matrix (PyBullet order).
        projection: The frame's projection matrix (PyBullet order).
        width: Image width in pixels.
        height: Image height in pixels.
        sample_offset: Where the renderer samples inside a pixel (0.5 = centre; 0.0 = TinyRenderer).
    """
    proj = gl_matrix(projection)
    x_ndc = 2.0 * (np.asarray(us, float) + sample_offset) / width - 1.0
    y_ndc = 1.0 - 2.0 * (np.asarray(vs, float) + 1.0 - sample_offset) / height
    z = np.asarray(depth_m, float)
    # eye space (camera looks along -z): x_ndc = (P00 * x + P02 * z_e) / -z_e with z_e = -z
    x_eye = (x_ndc * z + proj[0, 2] * z) / proj[0, 0]
    y_eye = (y_ndc * z + proj[1, 2] * z) / proj[1, 1]
    eye = np.stack([x_eye, y_eye, -z, np.ones_like(z)], axis=0)
    world = np.linalg.inv(gl_matrix(view)) @ eye
    return np.asarray(world[:3].T)


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """One rendered camera frame.

    Attributes:
        rgb: ``H x W x 3`` uint8 colour image.
        depth: ``H x W`` float32 depth in metres along the optical axis (``far`` where nothing was hit).
        segmentation: ``H x W`` int32 body ids (-1 = background), or None if the camera does not render it.
        labels: Body id -> body name, for every id that appears in ``segmentation``.
        view_matrix: View matrix, 16 floats, PyBullet (column-major) order.
        projection_matrix: Projection matrix, 16 floats, PyBullet order.
        eye: Camera position, metres, world frame.
        near: Near clipping plane, metres.
        far: Far clipping plane, metres.
        time: Sim time the frame was rendered at, seconds.
        sample_offset: Where the renderer samples inside a pixel (see the module docstring).
    """

    rgb: np.ndarray
    depth: np.ndarray
    segmentation: np.ndarray | None
    labels: Mapping[int, str]
    view_matrix: Matrix16
    projection_matrix: Matrix16
    eye: Vec3
    near: float
    far: float
    time: float
    sample_offset: float = 0.5

    @property
    def width(self) -> int:
        """Image width in pixels."""
        return int(self.rgb.shape[1])

    @property
    def height(self) -> int:
        """Image height in pixels."""
        return int(self.rgb.shape[0])

    def body_at(self, u: int, v: int) -> str | None:
        """Name of the body seen at pixel ``(u, v)`` (None for background or without segmentation)."""
        if self.segmentation is None:
            return None
        return self.labels.get(int(self.segmentation[v, u]))

    def body_mask(self, name: str) -> np.ndarray:
        """Boolean ``H x W`` mask of the pixels showing body ``name`` (all False if it is not in view)."""
        if self.segmentation is None:
            raise ValueError("this camera does not render segmentation (segmentation = false)")
        ids = [i for i, n in self.labels.items() if n == name]
        return np.isin(self.segmentation, ids)

    def point(self, u: float, v: float) -> Vec3:
        """World point (metres) seen at pixel ``(u, v)``, from the depth image."""
        ui, vi = int(round(u)), int(round(v))
        ui, vi = min(max(ui, 0), self.width - 1), min(max(vi, 0), self.height - 1)
        pts = deproject(np.array([u]), np.array([v]), np.array([self.depth[vi, ui]]), self.view_matrix,
                        self.projection_matrix, self.width, self.height, self.sample_offset)
        return (float(pts[0, 0]), float(pts[0, 1]), float(pts[0, 2]))

    def points(self, mask: np.ndarray) -> np.ndarray:
        """World points (N x 3, metres) of every pixel where ``mask`` is true, in row-major order."""
        vs, us = np.nonzero(mask)
        return deproject(us, vs, self.depth[vs, us], self.view_matrix, self.projection_matrix,
                         self.width, self.height, self.sample_offset)


@dataclass(frozen=True)
class Detection:
    """One coloured blob found by the ``colour_detector``.

    Attributes:
        colour: Name of the colour class, e.g. ``"red"``.
        pixel: Blob centroid ``(u, v)`` in pixels.
        area: Blob area in pixels.
        bbox: Bounding box ``(u, v, width, height)`` in pixels.
        position: Estimated object centre, metres, world frame (top face minus half the object height).
        top: Centre of the visible top face, metres, world frame.
        yaw: Footprint orientation about world +z, radians, folded into ``[-pi/4, pi/4)`` (a cube's four
            symmetric yaws are the same grasp); 0.0 when the footprint is too small to tell.
        extent: Footprint side lengths ``(long, short)`` in metres (from ``cv2.minAreaRect``).
    """

    colour: str
    pixel: tuple[float, float]
    area: int
    bbox: tuple[int, int, int, int]
    position: Vec3
    top: Vec3
    yaw: float
    extent: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class Detections:
    """What a ``colour_detector`` saw in one camera frame.

    Attributes:
        camera: Name of the camera sensor.
        time: Sim time of the frame the detections come from, seconds.
        items: Detections, sorted by colour name, then row, then column of the centroid.
        colours: Every colour class the detector knows, in config order.
    """

    camera: str
    time: float
    items: tuple[Detection, ...] = ()
    colours: tuple[str, ...] = field(default_factory=tuple)

    def of(self, colour: str) -> tuple[Detection, ...]:
        """Only the detections of one colour class."""
        return tuple(d for d in self.items if d.colour == colour)

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self.items)
