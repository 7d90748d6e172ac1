"""Rebuild a recorded scene in a DIRECT world and put it in any recorded pose: no physics is stepped.

The bodies come from the config held in the record's header (the same shapes, URDFs, scales and colours); every
frame then sets each body's base pose and joint positions from the pose log, which reproduces every link's pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robokit.errors import UserError
from robokit.record.format import RunRecord

SCENE_SECTIONS = ("world", "regions", "bodies", "robots")
FAR_AWAY = (0.0, 0.0, -1000.0)
"""Where a body removed during the run is parked (out of every view)."""


@dataclass
class Scene:
    """A DIRECT world holding a record's bodies, posed frame by frame."""

    world: Any
    rec: RunRecord
    joints: dict[str, list[int]]
    lowered: dict[str, float] = field(default_factory=dict)
    """Ground planes drawn this much lower (m) than recorded: see :func:`floor_drops`."""
    light_direction: list[float] | None = None
    """The light every camera of the run used when ``[randomize]`` drew one (None: the renderer's default)."""

    def set_frame(self, i: int) -> None:
        """Put every body in the pose of pose-log sample ``i``."""
        poses, world = self.rec.poses, self.world
        for name, indices in self.joints.items():
            bid = self.world.body(name)
            base = poses.get(f"base/{name}")
            if base is None:
                continue
            row = base[i]
            if np.isnan(row[0]):
                world.set_com_pose(bid, FAR_AWAY, (0, 0, 0, 1))
                continue
            position = row[:3].tolist()
            position[2] -= self.lowered.get(name, 0.0)
            world.set_com_pose(bid, position, row[3:7].tolist())
            q = poses.get(f"joints/{name}")
            if q is not None:
                for idx, value in zip(indices, q[i].tolist(), strict=True):
                    world.reset_joint(bid, idx, value)

    def close(self) -> None:
        self.world.close()

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def rebuild(rec: RunRecord, engine: str = "pybullet") -> Scene:
    """Build the record's bodies in a new DIRECT world (seeded as the run was, so scattered bodies start alike), of
    ``engine`` (``robokit video`` draws a MuJoCo run's scene in MuJoCo).

    Raises:
        UserError: The record has no pose log, or its config's bodies cannot be built here (a URDF is missing).
    """
    from robokit.config import build_config
    from robokit.core.simulation import spawn_bodies
    from robokit.core.world import World
    from robokit.plugin_api.plugins import load_plugins

    header = rec.header
    if not rec.has_poses:
        raise UserError(f"{rec.folder}: no pose log (poses.npz): the run was recorded with pose_hz = 0")
    raw = {k: v for k, v in header["config"].items() if k in SCENE_SECTIONS}
    raw["world"] = {k: v for k, v in raw.get("world", {}).items() if k != "gui"}
    base_dir = Path(header.get("config_dir") or ".")
    cfg = build_config(raw, load_plugins(), source=str(header.get("config_path", "<record>")), base_dir=base_dir)
    world = World.create(engine, gui=False, time_step=cfg.world.time_step, seed=int(header["seed"]), base_dir=base_dir)
    try:
        spawn_bodies(world, cfg)
        joints = {}
        for name, info in header["bodies"].items():
            joints[name] = [world.joint(name, j).index for j in info["joints"]]
        lowered = floor_drops(world)
        light = apply_drawn_looks(world, rec)
    except Exception:
        world.close()
        raise
    return Scene(world, rec, joints, lowered, light)


def apply_drawn_looks(world: Any, rec: RunRecord) -> list[float] | None:
    """Give the rebuilt bodies the colours ``[randomize]`` drew for the run (the record's ``randomize``/``drawn``
    event), so its video shows what its cameras saw; returns the drawn light direction, if any."""
    drawn = next((e for e in rec.events if e.get("source") == "randomize" and e.get("kind") == "drawn"), None)
    if drawn is None:
        return None
    for name, entry in drawn.get("bodies", {}).items():
        if "rgba" in entry and world.has_body(name):
            world.set_visual_rgba(name, entry["rgba"])
    light = drawn.get("light_direction")
    return None if light is None else [float(v) for v in light]


def floor_drops(world: Any) -> dict[str, float]:
    """How far to lower each ground plane (a body over 5 m across, however thick: ``plane.urdf``'s collision box is
    10 m deep) so that it lies under every other body: a table sunk to put its top at z = 0 has its top exactly in
    the floor's plane, and the renderer draws the two surfaces in the same place (z-fighting: the table vanishes).
    Drawing only; the run is unchanged.
    """
    boxes = {name: world.body_aabb(name) for name in world.body_names}
    ground = {n for n, (lo, hi) in boxes.items() if max(hi[0] - lo[0], hi[1] - lo[1]) > 5.0}
    others = [lo[2] for n, (lo, _) in boxes.items() if n not in ground]
    if not ground or not others:
        return {}
    lowest = min(others)
    return {n: boxes[n][1][2] - lowest + 0.002 for n in ground if boxes[n][1][2] > lowest - 0.002}


# ----------------------------------------------------------------- views
NAMED_VIEWS = {"iso": (45.0, -30.0), "front": (90.0, -15.0), "side": (0.0, -15.0), "top": (90.0, -89.0),
               "back": (-90.0, -15.0)}
"""Named views as (yaw, pitch) in degrees about the scene's centre, PyBullet's GUI convention."""


@dataclass(frozen=True)
class View:
    """A camera: ``eye``, ``target``, ``up`` (world, metres) and the vertical field of view in degrees."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov: float = 50.0


def body_boxes(world: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """Bounding box of every body smaller than 5 m across (ground planes excluded), metres; tables sunk below the
    floor do not reach lower than 5 cm under it."""
    boxes = []
    for name in world.body_names:
        lo, hi = (np.asarray(v, float) for v in world.body_aabb(name))
        if max(hi - lo) < 5.0:
            lo[2] = min(max(lo[2], -0.05), hi[2])
            boxes.append((lo, hi))
    return boxes


def scene_box(world: Any) -> tuple[np.ndarray, np.ndarray]:
    """Bounding box of :func:`body_boxes` (the unit cube when there is none), metres."""
    boxes = body_boxes(world)
    if not boxes:
        return np.zeros(3), np.ones(3)
    return np.min([lo for lo, _ in boxes], axis=0), np.max([hi for _, hi in boxes], axis=0)


def choose_view(scene: Scene, spec: str | None, aspect: float) -> View:
    """A view from ``--view``: a named view, a camera sensor's name, ``ex,ey,ez,tx,ty,tz``, or None (iso).

    A named view frames the bodies as they are at the first pose sample: it leaves the scene in that pose.

    Raises:
        UserError: An unknown name or a malformed list of numbers (the message lists the choices).
    """
    spec = spec or "iso"
    if "," in spec:
        try:
            v = [float(x) for x in spec.split(",")]
        except ValueError:
            v = []
        if len(v) != 6:
            raise UserError(f"--view: expected 6 numbers 'ex,ey,ez,tx,ty,tz' (eye and target, metres), got {spec!r}")
        return View((v[0], v[1], v[2]), (v[3], v[4], v[5]))
    sensors = scene.rec.header["config"].get("sensors", {})
    cam = sensors.get(spec)
    if isinstance(cam, dict) and cam.get("type") == "camera" and "mount_body" not in cam:
        return View(tuple(cam.get("eye", (1, 1, 1))), tuple(cam.get("target", (0, 0, 0.5))),  # type: ignore[arg-type]
                    tuple(cam.get("up", (0, 0, 1))), float(cam.get("fov", 60.0)))  # type: ignore[arg-type]
    if spec not in NAMED_VIEWS:
        cams = [n for n, c in sensors.items() if isinstance(c, dict) and c.get("type") == "camera"]
        raise UserError(f"--view: unknown view {spec!r}; choose one of {', '.join([*NAMED_VIEWS, *cams])} or "
                        f"'ex,ey,ez,tx,ty,tz'")
    if len(scene.rec.poses["t"]):
        scene.set_frame(0)  # the scene as the video starts (a robot spawned upright may start lower, at its ready pose)
    lo, hi = scene_box(scene.world)
    corners = [np.array([x, y, z]) for blo, bhi in body_boxes(scene.world)
               for x in (blo[0], bhi[0]) for y in (blo[1], bhi[1]) for z in (blo[2], bhi[2])]
    return orbit_view((lo + hi) / 2, corners or [lo, hi], *NAMED_VIEWS[spec], aspect=aspect)


FIT_MARGIN = 0.95
"""A named view keeps every body's box within this share of the picture's half-width and half-height from its
middle."""


def orbit_view(centre: Any, points: Any, yaw: float, pitch: float, *, aspect: float, fov: float = 50.0) -> View:
    """A camera at ``yaw``/``pitch`` (degrees) around ``centre``, just far enough back for every one of ``points``
    (the corners of each body's box) to fall inside the picture: a tall robot from its base to its top. The run
    page's replay opens on this view of the scene too."""
    centre = np.asarray(centre, float)
    y, p = math.radians(yaw), math.radians(pitch)
    back = np.array([math.cos(p) * math.cos(y + math.pi / 2), math.cos(p) * math.sin(y + math.pi / 2),
                     -math.sin(p)])
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    cam_up = np.cross(back, right)
    tan_v = math.tan(math.radians(fov) / 2) * FIT_MARGIN
    tan_h = tan_v * aspect
    dist = 0.3
    for point in points:
        # a point at c from the centre is at depth dist - c.back, sideways c.right and up c.up in the camera
        c = np.asarray(point, float) - centre
        dist = max(dist, c @ back + max(abs(c @ right) / tan_h, abs(c @ cam_up) / tan_v))
    eye = centre + back * dist
    up = (0.0, 0.0, 1.0) if pitch > -85 else (math.cos(y), math.sin(y), 0.0)
    return View(tuple(eye.tolist()), tuple(centre.tolist()), up, fov)  # type: ignore[arg-type]
