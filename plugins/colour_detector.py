"""``colour_detector`` sensor (lessons 05 and 08A): coloured blobs in a camera's image, located in the world.

It reads the latest frame of a ``camera`` sensor (``ctx.readings[camera]``), so it is a sensor that depends on
another sensor. Both are lazy: reading the detector renders at most one frame, and only if the camera is stale;
a detector read twice on the same frame returns the cached detections.

Pipeline, per colour class: RGB -> HSV (OpenCV), ``cv2.inRange`` threshold (a hue range with ``lo > hi`` wraps
around 0, as red does), morphological opening, 8-connected components with a minimum area. Each blob's pixels are
deprojected through the frame's depth, view and projection matrices; the highest ones form the top face, whose
``cv2.minAreaRect`` gives the footprint centre and yaw. The object's centre is the top face minus half of
``object_height``. Only the image and the depth are used: no segmentation, no body positions.
"""

from __future__ import annotations

import colorsys
import math
from typing import Any

import cv2
import numpy as np
from pydantic import Field, model_validator

from robokit import hookimpl
from robokit.components import Sensor, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, LookupNameError
from robokit.msgs.vision import CameraFrame, Detection, Detections

Vec2 = tuple[float, float]


class ColourClass(Schema):
    """An HSV range: ``hue_deg`` [lo, hi] in degrees 0..360 (wraps through 0 when lo > hi); ``saturation`` and
    ``value`` [lo, hi] as fractions 0..1."""

    hue_deg: Vec2
    saturation: Vec2 = (0.5, 1.0)
    value: Vec2 = (0.25, 1.0)

    @model_validator(mode="after")
    def _ranges(self) -> ColourClass:
        if not all(0.0 <= h <= 360.0 for h in self.hue_deg):
            raise ValueError(f"hue_deg must lie in 0..360, got {list(self.hue_deg)}")
        for name in ("saturation", "value"):
            lo, hi = getattr(self, name)
            if not 0.0 <= lo <= hi <= 1.0:
                raise ValueError(f"{name} must be [lo, hi] with 0 <= lo <= hi <= 1, got {[lo, hi]}")
        return self

    def contains_rgb(self, rgb: Any) -> bool:
        """True if a true colour (r, g, b as 0-1 floats, e.g. a body's ``rgba``) lies inside this class."""
        h, s, v = colorsys.rgb_to_hsv(*(min(1.0, max(0.0, float(c))) for c in tuple(rgb)[:3]))
        hue, (lo, hi) = h * 360.0, self.hue_deg
        in_hue = lo <= hue <= hi if lo <= hi else (hue >= lo or hue <= hi)
        return in_hue and self.saturation[0] <= s <= self.saturation[1] and self.value[0] <= v <= self.value[1]


DEFAULT_COLOURS: dict[str, ColourClass] = {
    "red": ColourClass(hue_deg=(340.0, 20.0)),
    "green": ColourClass(hue_deg=(90.0, 150.0)),
    "blue": ColourClass(hue_deg=(200.0, 260.0)),
    "yellow": ColourClass(hue_deg=(45.0, 70.0)),
}
"""Built-in colour classes; a config's ``colours`` table overrides them by name and may add more."""


class ColourDetectorConfig(Schema):
    """``camera``: the camera sensor's name; ``colours``: classes by name (merged over the defaults red, green,
    blue, yellow); ``min_area`` in pixels; ``open_px`` the opening kernel size in pixels (0 = none);
    ``object_height`` in metres (centre = top face minus half of it); ``top_tolerance`` in metres."""

    camera: str = "camera"
    colours: dict[str, ColourClass] = Field(default_factory=dict)
    min_area: int = Field(default=30, ge=1)
    open_px: int = Field(default=3, ge=0, le=31)
    object_height: float = Field(default=0.05, ge=0.0)
    top_tolerance: float = Field(default=0.006, gt=0.0)


def hsv_mask(hsv: np.ndarray, cls: ColourClass) -> np.ndarray:
    """uint8 mask (0/255) of the pixels of an OpenCV HSV image (H 0..179) inside a colour class."""
    s_lo, s_hi = (round(v * 255) for v in cls.saturation)
    v_lo, v_hi = (round(v * 255) for v in cls.value)
    h_lo, h_hi = (h / 2.0 for h in cls.hue_deg)
    spans = [(h_lo, h_hi)] if h_lo <= h_hi else [(h_lo, 180.0), (0.0, h_hi)]
    mask: np.ndarray = np.zeros(hsv.shape[:2], np.uint8)
    for lo, hi in spans:
        lower = np.array([math.ceil(lo), s_lo, v_lo], np.uint8)
        upper = np.array([min(179, math.floor(hi)), s_hi, v_hi], np.uint8)
        mask = cv2.bitwise_or(mask, cv2.inRange(hsv, lower, upper))
    return mask


def fold_yaw(angle_deg: float) -> float:
    """A rectangle angle in degrees folded into ``[-pi/4, pi/4)`` radians (90-degree symmetry)."""
    folded = (angle_deg + 45.0) % 90.0 - 45.0
    return math.radians(folded)


class ColourDetector(Sensor):
    """Coloured blobs in a camera frame with world positions deprojected from depth (lazy, one frame per read)."""

    reading_type = Detections
    example = {
        "config": {"camera": "cam", "object_height": 0.1},
        "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                   "cube": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0.0, "position": [0, 0, 0.05],
                            "rgba": [1, 0, 0, 1]}},
        "sensors": {"cam": {"type": "camera", "width": 64, "height": 48, "eye": [0.0, 0.0, 1.0],
                            "target": [0.0, 0.0, 0.0], "up": [1, 0, 0]}},
    }

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.cfg: ColourDetectorConfig = self.config
        cameras = [n for n, c in ctx.components.items() if getattr(c, "reading_type", None) is CameraFrame]
        if self.cfg.camera not in cameras:
            raise ConfigError(str(LookupNameError("camera sensor", self.cfg.camera, cameras)), key="camera")
        self.colours: dict[str, ColourClass] = {**DEFAULT_COLOURS, **self.cfg.colours}
        size = self.cfg.open_px
        self.kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size)) if size > 1 else None
        self._stamp = -2
        self._last: Detections | None = None

    def read(self) -> Detections:
        """Detections in the camera's latest frame (rendering it if stale; cached per frame)."""
        frame: CameraFrame = self.ctx.readings[self.cfg.camera]
        stamp = self.ctx.readings.stamp(self.cfg.camera) if hasattr(self.ctx.readings, "stamp") else -1
        if self._last is not None and stamp == self._stamp and stamp >= 0:
            return self._last
        self._stamp, self._last = stamp, self.detect(frame)
        return self._last

    def detect(self, frame: CameraFrame) -> Detections:
        """Every blob of every colour class in ``frame``, sorted by colour name, then centroid row and column."""
        hsv = cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2HSV)
        items: list[Detection] = []
        for colour, cls in self.colours.items():
            mask = hsv_mask(hsv, cls)
            if not cv2.countNonZero(mask):
                continue  # no pixel of this colour: no blob (opening and labelling an empty mask find none)
            if self.kernel is not None:
                mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, self.kernel)
            items.extend(self._blobs(colour, mask, frame))
        items.sort(key=lambda d: (d.colour, round(d.pixel[1], 3), round(d.pixel[0], 3)))
        return Detections(camera=self.cfg.camera, time=frame.time, items=tuple(items),
                          colours=tuple(self.colours))

    def _blobs(self, colour: str, mask: np.ndarray, frame: CameraFrame) -> list[Detection]:
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        out = []
        for i in range(1, count):
            area = int(stats[i, cv2.CC_STAT_AREA])
            if area < self.cfg.min_area:
                continue
            x, y, w, h = (int(stats[i, k]) for k in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP,
                                                       cv2.CC_STAT_WIDTH, cv2.CC_STAT_HEIGHT))
            located = self._locate(frame.points(labels == i))
            if located is None:
                continue
            top, yaw, extent = located
            centre = (top[0], top[1], top[2] - self.cfg.object_height / 2.0)
            out.append(Detection(colour=colour, pixel=(float(centroids[i, 0]), float(centroids[i, 1])), area=area,
                                 bbox=(x, y, w, h), position=centre, top=top, yaw=yaw, extent=extent))
        return out

    def _locate(self, pts: np.ndarray) -> tuple[Any, float, tuple[float, float]] | None:
        """Top-face centre (metres, world), footprint yaw (rad) and extent (m) of a blob's 3D points."""
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts) == 0:
            return None
        z_top = float(np.percentile(pts[:, 2], 98))
        top = pts[pts[:, 2] >= z_top - self.cfg.top_tolerance]
        z = float(np.median(top[:, 2]))
        if len(top) >= 5:
            (cx, cy), (w, h), angle = cv2.minAreaRect(top[:, :2].astype(np.float32))
            yaw = fold_yaw(angle)
            extent = (float(max(w, h)), float(min(w, h)))
        else:
            cx, cy = (float(v) for v in top[:, :2].mean(axis=0))
            yaw, extent = 0.0, (0.0, 0.0)
        return (float(cx), float(cy), z), yaw, extent


@hookimpl
def robokit_register_sensors(register):  # type: ignore[no-untyped-def]
    register("colour_detector", ColourDetector, ColourDetectorConfig)
