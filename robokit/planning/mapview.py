"""The planner's saved map, read back and drawn: ``map.pgm`` + ``map.yaml`` (ROS ``map_server``'s format) and
``map_plans.json`` (every path A* found), as one inline SVG for the run page.

The occupancy grid is embedded as a PNG with exactly the PGM's pixels (one pixel per cell, no scaling, no
colour change: the browser enlarges it without smoothing); the paths are SVG polylines on top, in the image's pixel
coordinates, so the picture can be checked against the files it came from.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from html import escape
from pathlib import Path

import numpy as np

MAP_FILES = ("map.pgm", "map.yaml")
PLANS_FILE = "map_plans.json"


@dataclass(frozen=True)
class SavedMap:
    """A saved grid: ``image`` (rows, cols) uint8 with row 0 the largest y; ``resolution`` m per cell;
    ``origin`` the world xy (m) of the image's bottom-left corner."""

    image: np.ndarray
    resolution: float
    origin: tuple[float, float]

    def to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """World xy (n, 2), m -> image coordinates (n, 2): column, row (row 0 at the top), in pixels."""
        rows = self.image.shape[0]
        col = (xy[:, 0] - self.origin[0]) / self.resolution
        row = rows - (xy[:, 1] - self.origin[1]) / self.resolution
        return np.column_stack([col, row])


def read_pgm(data: bytes) -> np.ndarray:
    """A binary (P5) 8-bit PGM -> (rows, cols) uint8. Raises ValueError on anything else."""
    fields: list[bytes] = []
    pos = 0
    while len(fields) < 4:
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while end < len(data) and not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    magic, cols, rows, maxval = fields[0], int(fields[1]), int(fields[2]), int(fields[3])
    if magic != b"P5" or maxval > 255:
        raise ValueError(f"not an 8-bit binary PGM (magic {magic!r}, maxval {maxval})")
    pixels = np.frombuffer(data, dtype=np.uint8, count=rows * cols, offset=pos + 1)
    return pixels.reshape(rows, cols)


def read_map(folder: Path) -> SavedMap | None:
    """The map saved in a run folder, or None when it has none (or a part is unreadable)."""
    pgm, meta = (folder / name for name in MAP_FILES)
    if not pgm.is_file() or not meta.is_file():
        return None
    values: dict[str, str] = {}
    for line in meta.read_text(encoding="utf-8").splitlines():
        key, _, value = line.partition(":")
        values[key.strip()] = value.strip()
    try:
        origin = [float(v) for v in values["origin"].strip("[]").split(",")[:2]]
        return SavedMap(read_pgm(pgm.read_bytes()), float(values["resolution"]), (origin[0], origin[1]))
    except (KeyError, ValueError, IndexError):
        return None


def read_plans(folder: Path) -> list[np.ndarray]:
    """The paths in ``map_plans.json`` (world xy, m, each (n, 2)); empty when there is none."""
    path = folder / PLANS_FILE
    if not path.is_file():
        return []
    try:
        plans = json.loads(path.read_text(encoding="utf-8"))["plans"]
        return [np.asarray(p["path"], float).reshape(-1, 2) for p in plans]
    except (KeyError, TypeError, ValueError):
        return []


def png_bytes(image: np.ndarray) -> bytes:
    """A greyscale image as PNG bytes (lossless: decoding gives the same array back)."""
    import cv2

    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise ValueError("PNG encoding failed")
    return bytes(buf)


def _polyline(points: np.ndarray, css: str) -> str:
    text = " ".join(f"{c:.2f},{r:.2f}" for c, r in points)
    return f"<polyline class='{css}' points='{text}'/>"


def map_svg(folder: Path, driven: np.ndarray | None, width: int = 640) -> str | None:
    """The saved map with every planned path (thin blue) and the driven path (orange) as inline SVG, or None.

    Args:
        folder: Run folder holding ``map.pgm`` + ``map.yaml`` (and ``map_plans.json``).
        driven: The robot's base positions over the run, world xy (n, 2), m (None: not drawn).
        width: Displayed width, CSS pixels.
    """
    saved = read_map(folder)
    if saved is None:
        return None
    rows, cols = saved.image.shape
    uri = "data:image/png;base64," + base64.b64encode(png_bytes(saved.image)).decode("ascii")
    parts = [f"<svg class='occupancy' xmlns='http://www.w3.org/2000/svg' viewBox='0 0 {cols} {rows}' "
             f"width='{width}' height='{round(width * rows / cols)}'>",
             "<style>polyline{fill:none;vector-effect:non-scaling-stroke;stroke-linejoin:round}"
             ".plan{stroke:#1e88e5;stroke-width:1;stroke-opacity:.45}.driven{stroke:#ef6c00;stroke-width:2.5}"
             "</style>",
             f"<image id='map-grid' href='{uri}' x='0' y='0' width='{cols}' height='{rows}' "
             "style='image-rendering:pixelated'/>"]
    parts += [_polyline(saved.to_pixels(p), "plan") for p in read_plans(folder) if len(p) >= 2]
    if driven is not None and len(driven) >= 2:
        parts.append(_polyline(saved.to_pixels(driven), "driven"))
    parts.append("</svg>")
    return "".join(parts)


def map_caption(folder: Path) -> str:
    """One line under the picture: size, resolution, origin, how many paths were planned."""
    saved = read_map(folder)
    if saved is None:
        return ""
    rows, cols = saved.image.shape
    n = len(read_plans(folder))
    return escape(f"occupancy grid {cols} x {rows} cells of {saved.resolution:g} m, origin ({saved.origin[0]:g}, "
                  f"{saved.origin[1]:g}) m: black occupied, white free, grey unknown; blue: the {n} path(s) A* "
                  f"planned; orange: the path driven")
