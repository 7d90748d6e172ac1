"""The sensors a page picks, as the live view shows them: a lidar's scan (drawn in the 3D scene), a camera's latest
image (JPEG, encoded by the server when a page asks for it) and the numbers of any other reading (plotted).

Only readings the run has already made are shown: a frame takes each picked slot's latest value as it stands
(:attr:`robokit.core.scheduler.Slot.value`), never computes a stale one, so the run measures, renders and saves
exactly what it does without a page. A sensor nobody in the run reads has no reading to show. Nothing here is built
unless a page (or ``--live-sensors``) asked for that sensor; a scan or a set of numbers is built once per reading.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from robokit.errors import UserError

MAX_ITEMS = 8
"""A sequence of numbers with at most this many items is plotted item by item (``wheel_speeds[0]``); longer ones,
and sequences of anything else, by their length (``items.count``)."""
JPEG_QUALITY = 90
"""Camera images are sent as JPEG at this quality, colour at full resolution (4:4:4: a small coloured object keeps
its colour): a 320 x 240 frame of a lesson's scene is a few tens of kilobytes."""


def kind_of(component: Any) -> str:
    """How the page shows a component's readings: ``scan`` (drawn in the scene), ``image`` or ``values``."""
    from robokit.msgs.mobile import LaserScan
    from robokit.msgs.vision import CameraFrame

    reading = getattr(component, "reading_type", None)
    if reading is LaserScan:
        return "scan"
    if reading is CameraFrame:
        return "image"
    return "values"


def numbers(value: Any, prefix: str = "", depth: int = 0) -> dict[str, float]:
    """A reading's numbers by field path (``normal_force``, ``pose.x``, ``wheel_speeds[1]``, ``items.count``):
    booleans as 0/1; text, None and non-finite numbers left out."""
    out: dict[str, float] = {}
    if depth > 4:
        return out
    if isinstance(value, (bool, np.bool_)):
        return {prefix: float(value)}
    if isinstance(value, (int, float, np.integer, np.floating)):
        number = float(value)
        return {prefix: number} if math.isfinite(number) else {}
    dot = prefix + "." if prefix else ""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        for field in dataclasses.fields(value):
            out.update(numbers(getattr(value, field.name), dot + field.name, depth + 1))
    elif isinstance(value, Mapping):
        for k, v in value.items():
            out.update(numbers(v, dot + str(k), depth + 1))
    elif isinstance(value, (list, tuple, np.ndarray)):
        items = np.asarray(value).ravel() if isinstance(value, np.ndarray) else value
        if len(items) <= MAX_ITEMS and all(isinstance(v, (int, float, np.integer, np.floating)) for v in items):
            for i, v in enumerate(items):
                out.update(numbers(v, f"{prefix}[{i}]", depth + 1))
        elif prefix:
            out[dot + "count"] = float(len(items))
    return out


class SensorFeed:
    """The run's readable slots (sensors and actuators) and which of them a page wants; builds a frame's
    ``sensors`` entry (:meth:`payload`) and serves camera images as JPEG (:meth:`jpeg`).

    Args:
        slots: The loop's slots by component name (:attr:`robokit.core.scheduler.TickScheduler.slots`).
        picked: Names always shown (``--live-sensors``).

    Raises:
        UserError: A picked name is not a sensor or actuator of the run.
    """

    def __init__(self, slots: Mapping[str, Any], picked: tuple[str, ...] = ()) -> None:
        self.slots = dict(slots)
        for name in picked:
            if name not in self.slots:
                raise UserError(f"--live-sensors: no sensor or actuator {name!r} in this run; it has "
                                f"{', '.join(self.slots) or '(none)'}")
        self.kinds = {name: kind_of(slot.component) for name, slot in self.slots.items()}
        self.picked = frozenset(picked)
        self.wanted: frozenset[str] = self.picked
        """What the next frame carries: the picked names and those an open page asked for."""
        self._asked: dict[int, frozenset[str]] = {}
        self._built: dict[str, tuple[int, dict[str, Any]]] = {}  # name -> (stamp, its payload)
        self._images: dict[str, tuple[int, np.ndarray]] = {}  # name -> (stamp, rgb) of the latest frame
        self._jpegs: dict[str, tuple[int, bytes]] = {}
        self._lock = threading.Lock()

    def describe(self) -> list[dict[str, Any]]:
        """What the page offers to pick: each slot's ``name``, ``kind`` and whether it is a ``sensor``."""
        return [{"name": name, "kind": self.kinds[name], "component": getattr(slot.component, "kind", "")}
                for name, slot in self.slots.items()]

    def ask(self, reader: int, names: list[str] | None) -> None:
        """Reader ``reader`` (an open page) wants ``names`` (None: the reader is gone).

        Raises:
            ValueError: A name that is not a sensor or actuator of the run.
        """
        unknown = [n for n in names or () if n not in self.slots]
        if unknown:
            raise ValueError(f"no sensor or actuator {unknown[0]!r} in this run; it has {', '.join(self.slots)}")
        with self._lock:
            if names is None:
                self._asked.pop(reader, None)
            else:
                self._asked[reader] = frozenset(names)
            self.wanted = self.picked.union(*self._asked.values())

    # ----------------------------------------------------------------- the loop's side
    def payload(self) -> dict[str, Any]:
        """Each wanted slot's latest reading as the page shows it, with the ``tick`` it was made at (-1: none yet)."""
        out: dict[str, Any] = {}
        for name in self.wanted:
            slot = self.slots[name]
            stamp = slot.stamp
            built = self._built.get(name)
            if built is None or built[0] != stamp:
                built = (stamp, self._build(name, slot.value, stamp))
                self._built[name] = built
            out[name] = built[1]
        return out

    def _build(self, name: str, value: Any, stamp: int) -> dict[str, Any]:
        kind = self.kinds[name]
        if stamp < 0 or value is None:
            return {"kind": kind, "tick": stamp}
        if kind == "scan":
            points = np.asarray(value.points, float).reshape(-1, 3)
            ranges = np.asarray(value.ranges, float)
            hit = np.isfinite(ranges)
            return {"kind": kind, "tick": stamp, "origin": [round(float(v), 4) for v in value.origin],
                    "points": np.round(points, 4).ravel().tolist(), "hit": "".join("1" if h else "0" for h in hit),
                    "ranges": np.round(np.where(hit, ranges, 0.0), 4).tolist(), "yaw": round(float(value.yaw), 6),
                    "angle_min": float(value.angle_min), "angle_increment": float(value.angle_increment)}
        if kind == "image":
            rgb = value.rgb
            self._images[name] = (stamp, rgb)  # a reference: the server encodes it when a page asks
            return {"kind": kind, "tick": stamp, "width": int(rgb.shape[1]), "height": int(rgb.shape[0])}
        return {"kind": kind, "tick": stamp, "values": numbers(value)}

    # ----------------------------------------------------------------- the server's side
    def jpeg(self, name: str) -> tuple[int, bytes] | None:
        """The latest image of camera ``name`` a frame carried, as JPEG, and the tick it was rendered at; encoded
        once per image, on the asking thread (never the loop's)."""
        import cv2

        with self._lock:
            image = self._images.get(name)
            if image is None:
                return None
            done = self._jpegs.get(name)
            if done is not None and done[0] == image[0]:
                return done
        ok, data = cv2.imencode(".jpg", cv2.cvtColor(image[1], cv2.COLOR_RGB2BGR),
                                [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY,
                                 cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444])
        if not ok:
            return None
        with self._lock:
            self._jpegs[name] = (image[0], data.tobytes())
        return image[0], data.tobytes()
