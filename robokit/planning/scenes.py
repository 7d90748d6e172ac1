"""Seeded navigation scenes for tests and benchmarks: config dicts (as TOML would parse them) for ``go_to_goal``
with the bundled diffbot and its lidar in a walled arena.

Kinds:

- ``"open"``: a few boxes scattered in the room; the straight line is mostly clear.
- ``"clutter"``: many boxes; the way weaves between them.
- ``"narrow"``: a wall across the room with one gap a little wider than the robot, away from the straight line.
- ``"dead_end"``: a deep U open towards the robot, the goal behind its closed end, and a wall on one side making
  the way round long: following the U's wall leads back into it.
- ``"room"``: the goal inside a room whose only door faces away from the robot.

Every wall is a static box 0.4 m high; :func:`scene` returns the config and the boxes' footprints.
"""

from __future__ import annotations

from typing import Any

import numpy as np

Box = tuple[float, float, float, float]
"""Footprint ``(xmin, ymin, xmax, ymax)``, m, world frame."""

KINDS = ("open", "clutter", "narrow", "dead_end", "room")
WALL = 0.1
HEIGHT = 0.4


def _box_body(box: Box) -> dict[str, Any]:
    x0, y0, x1, y1 = box
    return {"shape": "box", "size": [round(x1 - x0, 4), round(y1 - y0, 4), HEIGHT], "mass": 0,
            "position": [round((x0 + x1) / 2, 4), round((y0 + y1) / 2, 4), HEIGHT / 2], "rgba": [0.6, 0.6, 0.65, 1]}


def _arena(w: float, h: float) -> list[Box]:
    t = WALL
    return [(-t, -t, w + t, 0.0), (-t, h, w + t, h + t), (-t, 0.0, 0.0, h), (w, 0.0, w + t, h)]


def _free(p: tuple[float, float], boxes: list[Box], grow: float) -> bool:
    return all(not (b[0] - grow <= p[0] <= b[2] + grow and b[1] - grow <= p[1] <= b[3] + grow) for b in boxes)


def _scatter(rng: np.random.Generator, n: int, w: float, h: float, keep: list[tuple[float, float]]) -> list[Box]:
    boxes: list[Box] = []
    while len(boxes) < n:
        sx, sy = rng.uniform(0.3, 0.9, 2)
        cx, cy = rng.uniform(0.5, w - 0.5), rng.uniform(0.5, h - 0.5)
        b = (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)
        if all(_free(p, [b], 0.55) for p in keep) and all(_free(((o[0] + o[2]) / 2, (o[1] + o[3]) / 2), [b], 0.9)
                                                           for o in boxes):
            boxes.append(b)
    return boxes


def layout(kind: str, seed: int) -> tuple[list[Box], tuple[float, float, float], tuple[float, float]]:
    """Obstacle footprints, the robot's start ``(x, y, yaw_deg)`` and the goal ``(x, y)`` of one scene."""
    rng = np.random.default_rng(seed)
    if kind in ("open", "clutter"):
        w, h = 7.0, 5.0
        start = (0.6, float(rng.uniform(0.8, h - 0.8)), 0.0)
        goal = (w - 0.6, float(rng.uniform(0.8, h - 0.8)))
        inner = _scatter(rng, 4 if kind == "open" else 11, w, h, [start[:2], goal])
        return _arena(w, h) + inner, start, goal
    if kind == "narrow":
        w, h = 6.0, 5.0
        gap = float(rng.uniform(0.62, 0.7))
        side = 1 if rng.random() < 0.5 else -1
        centre = h / 2 + side * float(rng.uniform(1.2, 1.6))
        x = float(rng.uniform(2.7, 3.3))
        wall = [(x, 0.0, x + WALL, centre - gap / 2), (x, centre + gap / 2, x + WALL, h)]
        start = (1.0, h / 2 - side * float(rng.uniform(0.0, 0.6)), 0.0)
        goal = (w - 1.0, h / 2 - side * float(rng.uniform(0.0, 0.6)))
        return _arena(w, h) + wall, start, goal
    if kind == "dead_end":
        w, h = 8.0, 6.0
        depth, width = float(rng.uniform(1.8, 2.4)), float(rng.uniform(1.4, 1.8))
        bx = float(rng.uniform(4.2, 4.8))  # the U's closed end
        cy = h / 2 + float(rng.uniform(-0.3, 0.3))
        u = [(bx, cy - width / 2 - WALL, bx + WALL, cy + width / 2 + WALL),
             (bx - depth, cy + width / 2, bx, cy + width / 2 + WALL),
             (bx - depth, cy - width / 2 - WALL, bx, cy - width / 2)]
        side = 1 if rng.random() < 0.5 else -1  # a wall from the U's arm to the arena's side: one way round only
        if side > 0:
            block = [(bx - 0.8, cy + width / 2 + WALL, bx - 0.8 + WALL, h)]
        else:
            block = [(bx - 0.8, 0.0, bx - 0.8 + WALL, cy - width / 2 - WALL)]
        start = (bx - depth - 1.2, cy + float(rng.uniform(-0.2, 0.2)), 0.0)
        goal = (bx + 1.5, cy + float(rng.uniform(-0.4, 0.4)))
        return _arena(w, h) + u + block, start, goal
    if kind == "room":
        w, h = 8.0, 6.0
        rx0, ry0 = float(rng.uniform(4.0, 4.6)), float(rng.uniform(1.5, 2.0))
        rw, rh = 2.4, 2.4
        door = float(rng.uniform(0.8, 0.9))
        dy = ry0 + rh / 2
        room = [(rx0, ry0, rx0 + WALL, ry0 + rh), (rx0, ry0, rx0 + rw, ry0 + WALL),
                (rx0, ry0 + rh - WALL, rx0 + rw, ry0 + rh),
                (rx0 + rw - WALL, ry0, rx0 + rw, dy - door / 2), (rx0 + rw - WALL, dy + door / 2, rx0 + rw, ry0 + rh)]
        start = (1.0, dy + float(rng.uniform(-0.5, 0.5)), 0.0)
        goal = (rx0 + rw / 2 - 0.2, dy + float(rng.uniform(-0.3, 0.3)))
        return _arena(w, h) + room, start, goal
    raise ValueError(f"unknown scene kind {kind!r}; kinds: {', '.join(KINDS)}")


def scene(kind: str, seed: int, *, planner: str = "rules", timeout: float = 90.0) -> tuple[dict[str, Any], list[Box]]:
    """A ``go_to_goal`` config for one seeded scene, and its obstacle footprints (the true map)."""
    boxes, start, goal = layout(kind, seed)
    bodies: dict[str, Any] = {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}}
    for i, b in enumerate(boxes):
        bodies[f"wall_{i}"] = _box_body(b)
    cfg = {
        "world": {"seed": seed, "max_time": timeout + 5},
        "bodies": bodies,
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [start[0], start[1], 0.06],
                             "rpy_deg": [0, 0, start[2]]}},
        "sensors": {"scan": {"type": "lidar", "rate_hz": 10, "rays": 360, "range_max": 5.0}},
        "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
        "behaviour": {"type": "go_to_goal", "rate_hz": 20, "goal": [goal[0], goal[1]], "tolerance": 0.2,
                      "timeout": timeout, "planner": planner},
    }
    return cfg, boxes
