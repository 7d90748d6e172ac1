"""``camera`` sensor (lesson 05): RGB, metric depth and segmentation from a fixed or link-mounted camera.

Fixed camera: ``eye``, ``target`` and ``up`` in metres, world frame. Eye-in-hand: ``mount_body`` and ``mount_link``
name the link the camera rides on, ``offset_xyz`` / ``offset_rpy_deg`` place it in that link's frame; the camera
looks along the +z axis of the offset frame with image-up along its -y axis (x right, y down, z forward).

The sensor is lazy (the scheduler's default): when due it is only marked stale, and a frame is rendered the first
time something reads it. A 320x240 TinyRenderer frame costs ~64 ms, as much as ~450 physics steps. Headless worlds
use the TinyRenderer; a GUI world uses the OpenGL renderer (``renderer = "auto"`` or ``"opengl"``; ``"tiny"`` forces
the TinyRenderer, e.g. to get the same images with and without the GUI).

Depth is converted from the depth buffer ``d`` to metres with ``far * near / (far - (far - near) * d)``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from pydantic import Field, model_validator

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.msgs.vision import CameraFrame

Vec3 = tuple[float, float, float]


class CameraConfig(Schema):
    """Image size in pixels; ``fov`` vertical field of view in degrees; ``near``/``far`` clipping planes in metres.

    Fixed: ``eye``, ``target``, ``up`` (world frame, metres). Mounted: ``mount_body`` + ``mount_link`` and an
    offset in the link frame (``offset_xyz`` metres, ``offset_rpy_deg`` degrees).
    """

    width: int = Field(default=320, ge=8, le=4096)
    height: int = Field(default=240, ge=8, le=4096)
    fov: float = Field(default=60.0, gt=1.0, lt=179.0, description="vertical field of view, degrees")
    near: float = Field(default=0.05, gt=0.0)
    far: float = Field(default=5.0, gt=0.0)
    eye: Vec3 = (1.0, 1.0, 1.0)
    target: Vec3 = (0.0, 0.0, 0.5)
    up: Vec3 = (0.0, 0.0, 1.0)
    mount_body: str | None = None
    mount_link: str | None = None
    offset_xyz: Vec3 = (0.0, 0.0, 0.0)
    offset_rpy_deg: Vec3 = (0.0, 0.0, 0.0)
    segmentation: bool = True
    save: bool = Field(default=False, description="write every rendered frame as PNGs into the run folder")
    renderer: str = Field(default="auto", pattern="^(auto|tiny|opengl)$")

    @model_validator(mode="after")
    def _check(self) -> CameraConfig:
        if self.far <= self.near:
            raise ValueError(f"far ({self.far}) must be greater than near ({self.near})")
        if (self.mount_body is None) != (self.mount_link is None):
            raise ValueError("an eye-in-hand camera needs both 'mount_body' and 'mount_link'")
        return self


class Camera(Sensor):
    """RGB, metric depth and segmentation from a fixed or link-mounted camera (lazy: renders only when read)."""

    reading_type = CameraFrame
    example = {
        "config": {"width": 32, "height": 24, "eye": [0.0, 0.0, 1.0], "target": [0.0, 0.0, 0.0], "up": [1, 0, 0]},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "cube": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0.0, "position": [0, 0, 0.05]}},
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        cfg: CameraConfig = self.config
        self.cfg = cfg
        self.link: int | None = None
        self.body_id: int | None = None
        if cfg.mount_body is not None:
            ctx.body(cfg.mount_body, key="mount_body")
            assert cfg.mount_link is not None
            self.link = ctx.link(cfg.mount_body, cfg.mount_link, key="mount_link")
            self.body_id = self.world.body(cfg.mount_body)
        w = self.world
        self.projection = w.projection_matrix(cfg.fov, cfg.width / cfg.height, cfg.near, cfg.far)
        self.sample_offset = w.image_sample_offset(cfg.renderer)  # where a pixel is sampled (see vision_types)
        self._offset_orn = w.quaternion_from_euler([math.radians(a) for a in cfg.offset_rpy_deg])
        run_dir = getattr(ctx, "run_dir", None)
        wanted = cfg.save or getattr(ctx, "save_frames", False)
        self.save_dir = Path(run_dir) / "frames" if wanted and run_dir is not None else None

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Nothing to reset between episodes (robokit.gym): a frame depends only on the world."""

    def pose(self) -> tuple[Vec3, Vec3, Vec3]:
        """Current ``(eye, target, up)`` of the camera, metres, world frame."""
        cfg = self.cfg
        if self.link is None:
            return cfg.eye, cfg.target, cfg.up
        w = self.world
        pos, orn = w.pose(self.body_id, self.link)  # type: ignore[arg-type]
        eye, cam_orn = w.multiply_transforms(pos, orn, cfg.offset_xyz, self._offset_orn)
        rot = np.asarray(w.matrix_from_quaternion(cam_orn), dtype=float).reshape(3, 3)
        forward, down = rot[:, 2], rot[:, 1]
        target = np.asarray(eye) + forward
        return tuple(eye), tuple(float(v) for v in target), tuple(float(v) for v in -down)  # type: ignore[return-value]

    def in_view(self, point: Vec3) -> bool:
        """True if a point (metres, world) projects inside the image with the camera's current pose, between
        the near and far planes (occlusion is not considered)."""
        eye, target, up = self.pose()
        view = np.asarray(self.world.view_matrix(eye, target, up), float).reshape(4, 4).T
        proj = np.asarray(self.projection, float).reshape(4, 4).T
        clip = proj @ view @ np.array([*point, 1.0])
        if clip[3] <= 0:
            return False
        ndc = clip[:3] / clip[3]
        return bool(abs(ndc[0]) <= 1.0 and abs(ndc[1]) <= 1.0 and -1.0 <= ndc[2] <= 1.0)

    def read(self) -> CameraFrame:
        """Render one frame now (RGB, metric depth, segmentation) with the camera's current pose."""
        cfg = self.cfg
        eye, target, up = self.pose()
        view = self.world.view_matrix(eye, target, up)
        rgb, depth, segmentation = self.world.render(cfg.width, cfg.height, view, self.projection, near=cfg.near,
                                                     far=cfg.far, segmentation=cfg.segmentation,
                                                     renderer=cfg.renderer)
        labels = {}
        if segmentation is not None:
            for body_id in np.unique(segmentation):
                name = self.world.body_name(int(body_id)) if body_id >= 0 else None
                if name is not None:
                    labels[int(body_id)] = name
        frame = CameraFrame(rgb=np.ascontiguousarray(rgb), depth=depth, segmentation=segmentation, labels=labels,
                            view_matrix=view, projection_matrix=self.projection,
                            eye=tuple(float(v) for v in eye), near=cfg.near, far=cfg.far,  # type: ignore[arg-type]
                            time=self.world.time, sample_offset=self.sample_offset)
        if self.save_dir is not None:
            save_frame_pngs(self.save_dir, f"{self.name}_{self.world.tick:06d}", frame)
        return frame


def save_frame_pngs(folder: Path, stem: str, frame: CameraFrame) -> list[Path]:
    """Write a frame as ``<stem>_rgb.png``, ``<stem>_depth.png`` (near = yellow, far = dark blue, colour-mapped
    between the frame's near and far planes) and ``<stem>_seg.png`` (one colour per body, background black)."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"{stem}_rgb.png", folder / f"{stem}_depth.png"]
    cv2.imwrite(str(paths[0]), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
    scaled = np.clip((frame.depth - frame.near) / (frame.far - frame.near), 0.0, 1.0)
    cv2.imwrite(str(paths[1]), cv2.applyColorMap((255 * (1.0 - scaled)).astype(np.uint8), cv2.COLORMAP_VIRIDIS))
    if frame.segmentation is not None:
        paths.append(folder / f"{stem}_seg.png")
        cv2.imwrite(str(paths[2]), segmentation_colours(frame.segmentation))
    return paths


def segmentation_colours(seg: np.ndarray) -> np.ndarray:
    """A BGR image with a distinct, stable colour per body id (background, id < 0, black)."""
    ids = np.where(seg >= 0, seg & ((1 << 24) - 1), -1)
    # one colour per id, converted once: OpenCV's HSV->BGR rounds the same pixel differently (by one level) in its
    # vector lanes and in the tail of a row, which gave one body two colours
    present, where = np.unique(ids, return_inverse=True)
    golden = (present * 0.618034) % 1.0
    hsv = np.stack([(golden * 179).astype(np.uint8), np.full(present.shape, 200, np.uint8),
                    np.where(present >= 0, 230, 0).astype(np.uint8)], axis=-1)
    import cv2

    palette = cv2.cvtColor(hsv.reshape(1, -1, 3), cv2.COLOR_HSV2BGR).reshape(-1, 3)
    return palette[where.reshape(seg.shape)]


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("camera", Camera, CameraConfig)
