"""The top-down map (``robokit plot``'s ``map``) read back from its matplotlib figure and compared with the record it
was drawn from, over generated records.

Boxes are generated at any yaw (not only the quarter turns, where a rotation composed the wrong way still looks
right), anywhere, of any size; the robot drives a generated path with gaps (NaN rows) in it. The oracle is written
plainly here: a box's footprint is its four corners (+-half size) turned by its yaw with cos/sin and moved to its
first recorded position; the driven path is the record's x and y of the robot's base, gaps left out; waypoints, the
goal, the objects' start positions and the lidar's estimates sit where the config and result put them.

The lidar plot: the scan of the last sample at or before the asked time, in the robot's frame (slow tier).

The run page (``robokit view``) likewise: the times and seed under its title and its object table, cell by cell,
against the result and header they came from.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.record.format import RunRecord
from robokit.record.layout import POSES_FILE, RESULT_FILE, TRACE_FILE
from robokit.record.plots import _pyplot, plot_map

PROPS = settings(max_examples=10, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
TOL = 1e-4  # poses are stored as float32, as the recorder stores them

coord = st.floats(-5.0, 5.0, allow_nan=False)
yaws = st.floats(-math.pi, math.pi, allow_nan=False)


def quat_of_yaw(yaw: float) -> list[float]:
    return [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]


def footprint(size: tuple[float, float], x: float, y: float, yaw: float) -> np.ndarray:
    """The four xy corners of a box of ``size`` turned by ``yaw`` about its centre at (x, y)."""
    c, s = math.cos(yaw), math.sin(yaw)
    out = []
    for cx, cy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
        dx, dy = cx * size[0] / 2, cy * size[1] / 2
        out.append((x + dx * c - dy * s, y + dx * s + dy * c))
    return np.array(out)


@st.composite
def boxes(draw: st.DrawFn) -> dict[str, Any]:
    return {"size": (draw(st.floats(0.05, 3.0)), draw(st.floats(0.05, 3.0)), draw(st.floats(0.05, 1.0))),
            "start": (draw(coord), draw(coord), draw(yaws)), "later": (draw(coord), draw(coord), draw(yaws)),
            "mass": draw(st.sampled_from([0.0, 0.5, 2.0])), "flip": draw(st.booleans()),
            "copy": draw(st.booleans())}


@st.composite
def scenes(draw: st.DrawFn) -> dict[str, Any]:
    n = draw(st.integers(2, 10))
    path = [(draw(coord), draw(coord), draw(yaws)) for _ in range(n)]
    gaps = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    if all(gaps):
        gaps[draw(st.integers(0, n - 1))] = False
    return {"boxes": draw(st.lists(boxes(), min_size=3, max_size=8)), "path": path, "gaps": gaps,
            "objects": draw(st.lists(st.tuples(coord, coord, st.sampled_from(["cylinder", "sphere"])), max_size=3)),
            "waypoints": draw(st.lists(st.tuples(coord, coord), max_size=4)),
            "goal": draw(st.none() | st.tuples(coord, coord)),
            "found": draw(st.lists(st.tuples(st.tuples(coord, coord), st.none() | st.tuples(coord, coord)),
                                   max_size=3))}


def pose_row(x: float, y: float, yaw: float, flip: bool = False) -> list[float]:
    q = quat_of_yaw(yaw)
    return [x, y, 0.1, *(-v for v in q)] if flip else [x, y, 0.1, *q]


def write_record(folder: Path, scene: dict[str, Any]) -> RunRecord:
    """A run folder holding ``scene``: a diff-drive robot, its boxes and objects, waypoints or a goal, found objects."""
    n = len(scene["path"])
    config: dict[str, Any] = {"bodies": {}, "robots": {"robot": {"urdf": "robots/diffbot.urdf"}},
                              "actuators": {"drive": {"type": "diff_drive"}}, "behaviour": {"type": "patrol"}}
    bodies: dict[str, Any] = {"robot": {"links": ["base"], "joints": []}}
    poses: dict[str, np.ndarray] = {"t": np.arange(n) / 30, "tick": np.arange(n) * 8}
    path = np.array([pose_row(*p) for p in scene["path"]], np.float32)
    path[np.array(scene["gaps"])] = np.nan
    poses["base/robot"] = path
    for i, box in enumerate(scene["boxes"]):
        name = f"box{i}_0" if box["copy"] else f"box{i}"  # the first of a ``count = N`` body's copies
        config["bodies"][f"box{i}"] = {"shape": "box", "size": list(box["size"]), "mass": box["mass"]}
        bodies[name] = {"links": ["base"], "joints": []}
        poses[f"base/{name}"] = np.array([pose_row(*box["start"], box["flip"])]
                                         + [pose_row(*box["later"])] * (n - 1), np.float32)
    # never drawn: a floor-sized box (over 20 m across) and a box removed before the first sample (NaN pose)
    config["bodies"]["floor"] = {"shape": "box", "size": [30.0, 30.0, 0.1], "mass": 0}
    config["bodies"]["gone"] = {"shape": "box", "size": [0.3, 0.3, 0.3], "mass": 1}
    for name in ("floor", "gone"):
        bodies[name] = {"links": ["base"], "joints": []}
        poses[f"base/{name}"] = np.array([pose_row(0.0, 0.0, 0.3)] * n, np.float32)
    poses["base/gone"][0] = np.nan
    for i, (x, y, shape) in enumerate(scene["objects"]):
        name = f"obj{i}"
        config["bodies"][name] = {"shape": shape, "mass": 0.2}
        bodies[name] = {"links": ["base"], "joints": []}
        poses[f"base/{name}"] = np.array([pose_row(x, y, 0.0)] + [pose_row(x + 1, y - 1, 0.0)] * (n - 1),
                                         np.float32)
    if scene["waypoints"]:
        config["behaviour"]["waypoints"] = [list(w) for w in scene["waypoints"]]
    if scene["goal"] is not None:
        config["behaviour"]["goal"] = list(scene["goal"])
    found = [{"estimate": list(est), **({"true": list(true)} if true else {})} for est, true in scene["found"]]
    head = {"kind": "header", "schema": "robokit.record/1", "machines": [], "config": config, "bodies": bodies,
            "seed": 3}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / TRACE_FILE).write_text(json.dumps(head) + "\n", encoding="utf-8")
    (folder / RESULT_FILE).write_text(json.dumps({"sim_time": n / 30, "outcome": "succeeded",
                                                  "result": {"found": found}}), encoding="utf-8")
    np.savez(folder / POSES_FILE, **poses)  # type: ignore[arg-type]
    return RunRecord(folder)


def drawn_map(tmp_path_factory: pytest.TempPathFactory, scene: dict[str, Any]) -> tuple[Any, Any]:
    rec = write_record(tmp_path_factory.mktemp("run"), scene)
    plt = _pyplot()
    fig = plot_map(rec, plt)
    assert fig is not None
    return plt, fig


def same_points(got: np.ndarray, want: np.ndarray) -> bool:
    """Every point of ``want`` is one of ``got`` and the other way round (order aside), within TOL."""
    if len(got) != len(want):
        return False
    d = np.linalg.norm(got[:, None, :] - want[None, :, :], axis=2)
    return bool((d.min(axis=0) < TOL).all() and (d.min(axis=1) < TOL).all())


def lines(ax: Any, marker: str) -> list[np.ndarray]:
    return [np.asarray(ln.get_xydata(), float) for ln in ax.get_lines() if ln.get_marker() == marker]


@PROPS
@given(scenes())
def test_the_map_draws_every_box_path_mark_and_estimate_where_the_record_puts_it(
        tmp_path_factory: pytest.TempPathFactory, scene: dict[str, Any]) -> None:
    plt, fig = drawn_map(tmp_path_factory, scene)
    try:
        ax = fig.axes[0]
        boxes_are_their_yawed_footprints(ax, scene)
        the_path_is_the_recorded_x_and_y(ax, scene)
        marks_sit_where_config_and_result_put_them(ax, scene)
    finally:
        plt.close(fig)


def boxes_are_their_yawed_footprints(ax: Any, scene: dict[str, Any]) -> None:
    """Each box is its footprint turned by its yaw at its first recorded pose (not its last), static dark."""
    polygons = [(np.asarray(p.get_xy(), float), p.get_facecolor()) for p in ax.patches]
    assert len(polygons) == len(scene["boxes"])
    for (xy, colour), box in zip(polygons, scene["boxes"], strict=True):
        corners = xy[:-1] if np.allclose(xy[0], xy[-1]) else xy
        want = footprint(box["size"][:2], *box["start"])
        assert same_points(corners, want), (corners, want)
        # a rectangle traced around its edge: consecutive corners a side apart, not across a diagonal
        sides = sorted(np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1))
        assert sides == pytest.approx(sorted([box["size"][0]] * 2 + [box["size"][1]] * 2), abs=TOL)
        grey = 0.35 if box["mass"] == 0 else 0.75
        assert colour[:3] == pytest.approx((grey, grey, grey), abs=0.01)  # static dark, free light


def the_path_is_the_recorded_x_and_y(ax: Any, scene: dict[str, Any]) -> None:
    """The driven path is the robot's recorded x and y, its gaps left out; the start its first drawn point."""
    path = next(ln for ln in ax.get_lines() if ln.get_label() == "driven path")
    start = next(ln for ln in ax.get_lines() if ln.get_label() == "start")
    xy, first = np.asarray(path.get_xydata(), float), np.asarray(start.get_xydata(), float)
    labels, aspect = (ax.get_xlabel(), ax.get_ylabel()), ax.get_aspect()
    want = np.array([(x, y) for (x, y, _), gap in zip(scene["path"], scene["gaps"], strict=True) if not gap])
    assert xy.shape == want.shape and np.allclose(xy, want, atol=TOL)
    assert np.allclose(first, want[:1], atol=TOL)
    assert labels == ("x (m)", "y (m)") and aspect == 1.0  # metres both ways, one metre as long in x as in y


def marks_sit_where_config_and_result_put_them(ax: Any, scene: dict[str, Any]) -> None:
    """Waypoints (or the goal) numbered in order, objects at their start, estimates joined to the truth, and a
    view that holds everything drawn."""
    stars, dots, crosses = lines(ax, "*"), lines(ax, "o"), lines(ax, "x")
    notes = [(t.get_text(), tuple(float(v) for v in t.xy)) for t in ax.texts]
    links = [np.asarray(ln.get_xydata(), float) for ln in ax.get_lines()
             if ln.get_marker() in ("None", "", None) and ln.get_label() != "driven path"]
    xlim, ylim = ax.get_xlim(), ax.get_ylim()
    marks = scene["waypoints"] or ([scene["goal"]] if scene["goal"] is not None else [])
    assert len(stars) == len(notes) == len(marks)
    for star, (text, at), i, mark in zip(stars, notes, range(len(marks)), marks, strict=True):
        assert np.allclose(star, [mark]) and np.allclose(at, mark) and text == str(i)  # numbered in order
    assert len(dots) == len(scene["objects"])
    for dot, (x, y, _) in zip(dots, scene["objects"], strict=True):
        assert np.allclose(dot, [[x, y]], atol=TOL)  # where the object started, not where it ended
    assert len(crosses) == len(scene["found"])
    assert all(np.allclose(c, [est]) for c, (est, _) in zip(crosses, scene["found"], strict=True))
    pairs = [np.array([est, true]) for est, true in scene["found"] if true]
    assert len(links) == len(pairs) and all(np.allclose(a, b) for a, b in zip(links, pairs, strict=True))
    # the view holds everything drawn
    points = [footprint(b["size"][:2], *b["start"]) for b in scene["boxes"]]
    points += [np.array([(x, y)]) for (x, y, _), gap in zip(scene["path"], scene["gaps"], strict=True) if not gap]
    points += [np.array([m]) for m in marks] + [np.array([(x, y)]) for x, y, _ in scene["objects"]]
    points += pairs + [np.array([est]) for est, _ in scene["found"]]
    every = np.vstack(points)
    assert (every[:, 0] >= xlim[0] - TOL).all() and (every[:, 0] <= xlim[1] + TOL).all()
    assert (every[:, 1] >= ylim[0] - TOL).all() and (every[:, 1] <= ylim[1] + TOL).all()


# ------------------------------------------------------------------------------------------ the run page
cells = st.one_of(st.none(), st.integers(-9, 99), st.floats(-5, 5, allow_nan=False), st.sampled_from(["cup", "a<b"]),
                  st.lists(st.floats(-5, 5, allow_nan=False), min_size=2, max_size=3))


@settings(PROPS, max_examples=12)
@given(st.floats(0, 1e4, allow_nan=False), st.floats(0, 1e4, allow_nan=False), st.integers(0, 2**31),
       st.sampled_from(["objects", "found"]),
       st.lists(st.dictionaries(st.sampled_from(["name", "estimate", "true", "error_m"]), cells, min_size=1),
                min_size=1, max_size=4))
def test_the_run_pages_times_seed_and_object_table_are_the_records(
        tmp_path_factory: pytest.TempPathFactory, sim: float, wall: float, seed: int, key: str,
        items: list[dict[str, Any]]) -> None:
    """The page's line under its title shows the result's sim and wall seconds (two decimals, each its own field)
    and the header's seed; its object table has one row per item of the result's list and one column per key
    (first seen first), each cell that item's value (a list as JSON, a missing or null value blank)."""
    from robokit.record.page import build_page

    folder = tmp_path_factory.mktemp("run")
    head = {"kind": "header", "schema": "robokit.record/1", "machines": [], "config": {}, "bodies": {}, "seed": seed}
    (folder / TRACE_FILE).write_text(json.dumps(head) + "\n", encoding="utf-8")
    (folder / RESULT_FILE).write_text(json.dumps({"outcome": "succeeded", "sim_time": sim, "wall_time": wall,
                                                  "result": {key: items}}), encoding="utf-8")
    page = build_page(RunRecord(folder), None, [])
    meta = re.search(r"<p class='meta'>run .*?</p>", page)
    assert meta is not None
    line = html.unescape(meta.group(0))
    assert f"seed {seed} " in line
    for field, value in (("sim", sim), ("wall", wall)):
        shown = re.search(rf" {field} (\d+\.\d\d) s ", line)
        assert shown is not None and abs(float(shown.group(1)) - value) <= 0.005 + 1e-9, (field, value, line)
    section = page[page.index("<h2>Objects"):]
    table = section[section.index("<table>"):section.index("</table>")]
    columns = []
    for item in items:
        columns += [k for k in item if k not in columns]
    assert [html.unescape(c) for c in re.findall(r"<th>(.*?)</th>", table)] == columns
    rows = [[html.unescape(c) for c in re.findall(r"<td>(.*?)</td>", row)]
            for row in re.findall(r"<tr>((?:<td>.*?</td>)+)</tr>", table)]
    want = [["" if item.get(c) is None else json.dumps(item[c]) if isinstance(item[c], list) else str(item[c])
             for c in columns] for item in items]
    assert rows == want


# ------------------------------------------------------------------------------------------ the lidar plot
@pytest.mark.slow  # a DIRECT world rebuilt per example
@settings(PROPS, max_examples=6)
@given(st.lists(st.tuples(coord, coord, yaws), min_size=2, max_size=5), st.floats(0.0, 0.3), st.floats(1.2, 3.0),
       st.floats(-math.pi, math.pi))
def test_the_lidar_plot_is_the_scan_at_the_last_sample_not_after_its_time_in_the_robots_frame(
        tmp_path_factory: pytest.TempPathFactory, frames: list[tuple[float, float, float]], at: float,
        distance: float, bearing: float) -> None:
    """``robokit plot --scan-at T``: the scan of the last pose sample at or before T (its time in the title), drawn in
    the robot's frame: a post at a world bearing from the robot of that sample shows up at that bearing minus the
    robot's yaw."""
    from robokit.record.plots import plot_lidar

    n = len(frames)
    t = np.arange(n) / 10
    i = max(k for k in range(n) if t[k] <= at + 1e-9) if at >= 0 else 0
    x, y, yaw = frames[min(i, n - 1)]
    post = (x + distance * math.cos(bearing), y + distance * math.sin(bearing))
    config = {"robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
              "bodies": {"post": {"shape": "box", "size": [0.1, 0.1, 0.6], "mass": 0, "position": [9, 9, 0.3]}},
              "sensors": {"scan": {"type": "lidar", "link": "lidar_link", "rays": 360, "range_max": 5.0}},
              "actuators": {"drive": {"type": "diff_drive"}}}
    folder = tmp_path_factory.mktemp("run")
    head = {"kind": "header", "schema": "robokit.record/1", "machines": [], "config": config, "seed": 0,
            "bodies": {"robot": {"links": ["base"], "joints": []}, "post": {"links": ["base"], "joints": []}}}
    (folder / TRACE_FILE).write_text(json.dumps(head) + "\n", encoding="utf-8")
    np.savez(folder / POSES_FILE, t=t, tick=np.arange(n) * 24,  # type: ignore[arg-type]
             **{"base/robot": np.array([[fx, fy, 0.06, *quat_of_yaw(fyaw)] for fx, fy, fyaw in frames]),
                "base/post": np.array([[*post, 0.3, 0, 0, 0, 1]] * n)})
    plt = _pyplot()
    fig = plot_lidar(RunRecord(folder), plt, at)
    try:
        ax = fig.axes[0]
        title = ax.get_title()
        hits = np.asarray(ax.collections[0].get_offsets(), float)  # (angle, range) of the returns
    finally:
        plt.close(fig)
    assert f"at t = {t[i]:.2f} s" in title
    assert len(hits)
    want = (bearing - yaw + math.pi) % (2 * math.pi) - math.pi
    nearest = hits[np.argmin(hits[:, 1])]
    off = abs((nearest[0] - want + math.pi) % (2 * math.pi) - math.pi)
    assert off < math.radians(6), (math.degrees(nearest[0]), math.degrees(want))
    assert abs(nearest[1] - distance) < 0.2
