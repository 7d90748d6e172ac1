"""Exported lidar scans of a lidar mounted turned (``yaw_offset_deg``) sit where the rays went in the world.

``robokit export`` re-casts every lidar on the recorded poses (``robokit.record.export.lidar_scans``): a scan's
``origin`` and ``quaternion`` are the sensor's frame in the world and its ``angles`` are counter-clockwise from the
sensor's +x, so a viewer draws hit ``k`` at ``origin + R(quaternion) (r cos a, r sin a, 0)``. A diffbot turned 143
degrees (no identity, no half turn) stands in a walled square with two lidars on its lidar link, turned by 90 and by
-35 degrees. The oracles: the sensor frame's heading is the recorded base heading plus ``yaw_offset_deg`` (in
degrees: 90 of them are a quarter turn), and every hit, drawn as a viewer draws it, lies on the surface of a wall.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.export import lidar_scans
from robokit.record.format import find_run

ROOT = Path(__file__).resolve().parents[1]
DIFFBOT = ROOT / "robokit" / "data" / "robots" / "diffbot.urdf"
OFFSETS = {"ahead_left": 90.0, "right": -35.0}
WALLS = {  # name: centre (x, y), half extents (x, y); 0.6 m high, axis-aligned, a 3 m square round the robot
    "north": ((0.3, 1.3), (1.6, 0.05)), "south": ((0.3, -1.7), (1.6, 0.05)),
    "east": ((1.8, -0.2), (0.05, 1.6)), "west": ((-1.2, -0.2), (0.05, 1.6)),
}


def scene() -> str:
    text = f"""
[world]
max_time = 0.2

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[robots.robot]
urdf = "{DIFFBOT}"
position = [0.3, -0.2, 0.06]
rpy_deg = [0, 0, 143]
"""
    for name, ((x, y), (hx, hy)) in WALLS.items():
        text += (f"\n[bodies.{name}]\nshape = \"box\"\nsize = [{2 * hx}, {2 * hy}, 0.6]\nmass = 0\n"
                 f"position = [{x}, {y}, 0.3]\n")
    for name, yaw in OFFSETS.items():
        text += f"\n[sensors.{name}]\ntype = \"lidar\"\nrays = 24\nrange_max = 4.0\nyaw_offset_deg = {yaw}\n"
    return text


@pytest.fixture(scope="module")
def scans(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, list[tuple[str, float, dict[str, Any]]]]:
    folder = tmp_path_factory.mktemp("lidar_export")
    (folder / "scene.toml").write_text(scene(), encoding="utf-8")
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["run", "scene.toml", "--quiet"]) == 0
    finally:
        os.chdir(cwd)
    rec = find_run("last", folder / "results")
    return rec, list(lidar_scans(rec))


def heading(q: Any) -> float:
    x, y, z, w = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def wall_gap(p: np.ndarray) -> float:
    """How far a point is from the surface of the nearest wall, m (the walls' own geometry, worked out here)."""
    gaps = []
    for (x, y), (hx, hy) in WALLS.values():
        d = np.abs(p[:2] - np.array([x, y])) - np.array([hx, hy])
        outside = float(np.linalg.norm(np.maximum(d, 0.0)))
        gaps.append(outside if outside > 0 else -float(d.max()))
    return min(gaps)


def test_each_scan_frame_is_the_link_turned_by_its_offset_in_degrees(scans: Any) -> None:
    rec, found = scans
    base = rec.poses["base/robot"]
    t = [float(v) for v in rec.poses["t"]]
    assert sorted({name for name, _, _ in found}) == sorted(OFFSETS) and len(found) == 2 * len(t)
    for name, when, scan in found:
        i = t.index(when)
        want = heading(base[i, 3:]) + math.radians(OFFSETS[name])
        assert abs(math.remainder(heading(scan["quaternion"]) - want, 2 * math.pi)) < 1e-3, (name, when)


def test_every_exported_hit_lies_on_a_wall(scans: Any) -> None:
    _, found = scans
    hits = 0
    for name, _, scan in found:
        origin = np.asarray(scan["origin"], float)
        q = scan["quaternion"]
        x, y, z, w = (float(v) for v in q)
        rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        for a, r in zip(scan["angles"], scan["ranges"], strict=True):
            assert math.isfinite(r), f"{name}: every ray of a walled square meets a wall"
            p = origin + rot @ np.array([r * math.cos(a), r * math.sin(a), 0.0])
            assert wall_gap(p) < 2e-3, (name, a, r, p.tolist())
            hits += 1
    assert hits == 2 * 24 * (len(found) // 2)
