"""The planner's map on the run page: ``robokit view`` of a ``planner = "astar"`` run shows the occupancy grid saved
in ``map.pgm`` pixel for pixel, the paths A* planned and the path the robot drove, placed by ``map.yaml``."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
import tomllib

from robokit.cli import main
from robokit.planning import GridConfig, OccupancyGrid
from robokit.planning.mapview import map_svg

ROOT = Path(__file__).resolve().parents[1]


def pgm_pixels(data: bytes) -> np.ndarray:
    """A P5 PGM as written by the grid (no comments): header of four fields, then rows."""
    magic, cols, rows, maxval, pixels = data.split(maxsplit=4)
    assert magic == b"P5" and int(maxval) == 255
    return np.frombuffer(pixels[: int(cols) * int(rows)], np.uint8).reshape(int(rows), int(cols))


def svg_parts(html: str) -> tuple[np.ndarray, dict[str, list[np.ndarray]], tuple[int, int]]:
    """The embedded PNG decoded, the polylines by class (pixel coordinates) and the viewBox size."""
    svg = re.search(r"<svg class='occupancy'.*?</svg>", html, re.S)
    assert svg is not None, "no map on the page"
    text = svg.group(0)
    png = base64.b64decode(re.search(r"href='data:image/png;base64,([^']+)'", text).group(1))
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    lines: dict[str, list[np.ndarray]] = {}
    for css, points in re.findall(r"<polyline class='(\w+)' points='([^']*)'", text):
        pts = np.array([[float(v) for v in p.split(",")] for p in points.split()])
        lines.setdefault(css, []).append(pts)
    w, h = (int(v) for v in re.search(r"viewBox='0 0 (\d+) (\d+)'", text).groups())
    return image, lines, (w, h)


def to_world(pixels: np.ndarray, yaml_text: str, rows: int) -> np.ndarray:
    res = float(re.search(r"resolution: ([\d.]+)", yaml_text).group(1))
    ox, oy = (float(v) for v in re.search(r"origin: \[([-\d.]+), ([-\d.]+)", yaml_text).groups())
    return np.column_stack([ox + pixels[:, 0] * res, oy + (rows - pixels[:, 1]) * res])


def test_map_svg_embeds_the_grid_unchanged_and_places_paths_by_its_origin(tmp_path: Path) -> None:
    grid = OccupancyGrid((-1.0, -2.0), (3.0, 1.0), GridConfig(resolution=0.1), clearance_cap=1.0)
    grid.mark_boxes([(0.0, 0.0, 1.0, 0.5)])
    (tmp_path / "map.pgm").write_bytes(grid.to_pgm())
    (tmp_path / "map.yaml").write_text(grid.map_yaml("map.pgm"))
    plan = [[-0.5, -1.5], [2.5, 0.8]]
    (tmp_path / "map_plans.json").write_text(json.dumps({"plans": [{"t": 0.0, "goal": plan[-1], "path": plan}]}))
    driven = np.array([[-0.5, -1.5], [0.0, -1.0], [2.5, 0.8]])
    image, lines, (w, h) = svg_parts(map_svg(tmp_path, driven) or "")
    expected = pgm_pixels((tmp_path / "map.pgm").read_bytes())
    assert image.shape == expected.shape == (h, w) and np.array_equal(image, expected)
    assert (expected == 0).any() and (expected == 205).any()  # the box is there, and unknown space
    yaml_text = (tmp_path / "map.yaml").read_text()
    assert np.allclose(to_world(lines["plan"][0], yaml_text, h), plan, atol=0.01)
    assert np.allclose(to_world(lines["driven"][0], yaml_text, h), driven, atol=0.01)
    assert map_svg(tmp_path / "nothing", driven) is None


@pytest.mark.slow
def test_the_run_page_of_an_astar_run_shows_its_map_plans_and_driven_path(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(ROOT / "configs" / "plan_dead_end.toml"), "--quiet"]) == 0
    (folder,) = (tmp_path / "results").iterdir()
    assert main(["view", str(folder), "--no-video", "--no-replay", "--output", str(tmp_path / "page.html")]) == 0
    html = (tmp_path / "page.html").read_text(encoding="utf-8")
    image, lines, (w, h) = svg_parts(html)
    expected = pgm_pixels((folder / "map.pgm").read_bytes())
    assert np.array_equal(image, expected) and image.shape == (h, w)
    yaml_text = (folder / "map.yaml").read_text()
    with np.load(folder / "poses.npz") as poses:
        base = poses["base/robot"][:, :2]
    driven = to_world(lines["driven"][0], yaml_text, h)
    assert np.allclose(driven, base[~np.isnan(base[:, 0])], atol=0.01)
    plans = json.loads((folder / "map_plans.json").read_text())["plans"]
    assert len(lines["plan"]) == len(plans) >= 1
    goal = tomllib.loads((ROOT / "configs" / "plan_dead_end.toml").read_text())["behaviour"]["goal"]
    first = to_world(lines["plan"][0], yaml_text, h)
    assert np.allclose(first[0], base[0], atol=0.05)  # planned from where the robot stood...
    assert all(np.allclose(to_world(p, yaml_text, h)[-1], goal, atol=0.01) for p in lines["plan"])  # ...to the goal
    # Every planned point lies on a cell the saved map shows free or unknown, never on an occupied one.
    for pts in lines["plan"]:
        cols, rows = np.clip(pts[:, 0].astype(int), 0, w - 1), np.clip(pts[:, 1].astype(int), 0, h - 1)
        assert (expected[rows, cols] != 0).all()
