"""The live world as the page's viewer draws it: the replay viewer's payload (``robokit/data/replay.js``) built from
a running world, and every drawn link's pose now.

A world of another engine (MuJoCo) is drawn as ``robokit view`` draws its record: the shapes are read once from the
config's bodies built in a PyBullet DIRECT world (the same URDFs, the same links), which is closed again at once;
every frame's link poses are the running world's own (:meth:`robokit.core.world.World.pose`, each link's frame as
the model file defines it)."""

from __future__ import annotations

import base64
import math
from pathlib import Path
from typing import Any

import numpy as np


def _base_frame(client: Any, bid: int) -> tuple[Any, Any]:
    """A body's URDF base-link frame (PyBullet's base pose is its centre of mass)."""
    pos, orn = client.getBasePositionAndOrientation(bid)
    info = client.getDynamicsInfo(bid, -1)
    inv_pos, inv_orn = client.invertTransform(info[3], info[4])
    return client.multiplyTransforms(pos, orn, inv_pos, inv_orn)


def scene_payload(sim: Any) -> tuple[dict[str, Any], list[Any]]:
    """What the replay viewer (``robokit/data/replay.js``) needs to draw the live world: its ``RK_REPLAY`` payload
    with one pose sample (the scene now), and the drawn links (for :func:`link_poses`)."""
    from robokit.record.scene import NAMED_VIEWS, body_boxes, orbit_view, scene_box

    world = sim.world
    links, items = visual_links(world) if world.engine == "pybullet" else _mirrored_links(sim)
    lo, hi = scene_box(world)
    corners = [np.array([x, y, z]) for blo, bhi in body_boxes(world)
               for x in (blo[0], bhi[0]) for y in (blo[1], bhi[1]) for z in (blo[2], bhi[2])]
    view = orbit_view((lo + hi) / 2, corners or [lo, hi], *NAMED_VIEWS["iso"], aspect=4 / 3)
    poses = np.asarray([v if v is not None else math.nan for v in link_poses(world, links)], np.float32)
    return ({"links": [link.path for link in links], "shapes": items, "meshes": [], "frames": [],
             "view": {"eye": view.eye, "target": view.target, "up": view.up, "fov": view.fov},
             "t": _b64(np.zeros(1, np.float32)), "poses": _b64(poses), "duration": 0.0, "machines": []}, links)


def visual_links(world: Any) -> tuple[list[Any], list[dict[str, Any]]]:
    """The links that carry visual shapes (:class:`robokit.record.replay.Link`) and those shapes as the replay's
    payload holds them, a mesh named by its file (``mesh_file``, for :func:`add_meshes`)."""
    from robokit.record.replay import GEOMETRY, Link

    client = world.client
    links: list[Any] = []
    items: list[dict[str, Any]] = []
    for name in world.body_names:
        bid = world.body(name)
        frame_of: dict[int, int] = {}
        for s in client.getVisualShapeData(bid):
            index, kind = int(s[1]), GEOMETRY.get(int(s[2]))
            if kind is None or (kind == "mesh" and not s[4].decode(errors="replace").lower().endswith(".obj")):
                continue
            if index not in frame_of:
                link = (client.getBodyInfo(bid)[0].decode() or "base") if index < 0 else \
                    client.getJointInfo(bid, index)[12].decode()
                frame_of[index] = len(links)
                links.append(Link(name, link, index))
            item: dict[str, Any] = {"frame": frame_of[index], "kind": kind, "size": list(s[3]),
                                    "rgba": [float(v) for v in s[7]], "position": list(s[5]),
                                    "quaternion": list(s[6])}
            if kind == "mesh":
                item["mesh_file"] = s[4].decode(errors="replace")
            items.append(item)
    return links, items


def _mirrored_links(sim: Any) -> tuple[list[Any], list[dict[str, Any]]]:
    """:func:`visual_links` of a world of another engine: its config's bodies built in a PyBullet DIRECT world give
    the shapes; each link is named by its index in the running world (found by the link's name)."""
    from robokit.core.simulation import spawn_bodies
    from robokit.core.world import World
    from robokit.record.replay import Link

    world = sim.world
    mirror = World.create("pybullet", gui=False, time_step=world.time_step, seed=world.seed,
                          base_dir=sim.config.base_dir)
    try:
        spawn_bodies(mirror, sim.config)
        links, items = visual_links(mirror)
    finally:
        mirror.close()
    index: dict[int, int] = {}
    kept: list[Any] = []
    for k, link in enumerate(links):
        if not world.has_body(link.body):
            continue
        try:
            where = -1 if link.index < 0 else world.link(link.body, link.link)
        except LookupError:  # a link the engine does not keep as a link of its own: not drawn
            continue
        index[k] = len(kept)
        kept.append(Link(link.body, link.link, where))
    return kept, [{**item, "frame": index[item["frame"]]} for item in items if item["frame"] in index]


def add_meshes(scene: dict[str, Any]) -> dict[str, Any]:
    """:func:`scene_payload`'s payload with its meshes read (OBJ files, each once); a shape whose mesh cannot be read
    is left out; a textured mesh takes its texture's mean colour, as the run page's replay draws it. Reading files
    takes a while: the server does it when a page first asks, not the loop."""
    from robokit.record.replay import read_obj, texture_tint

    index: dict[str, int | None] = {}
    tints: dict[str, tuple[float, float, float] | None] = {}
    meshes: list[dict[str, str]] = []
    shapes = []
    for item in scene["shapes"]:
        path = item.get("mesh_file")
        if path is None:
            shapes.append(item)
            continue
        if path not in index:
            got = read_obj(Path(path))
            index[path] = None if got is None else len(meshes)
            if got is not None:
                meshes.append({"vertices": _b64(got[0]), "triangles": _b64(got[1])})
        if index[path] is None:
            continue
        rgba, tint = item["rgba"], tints.setdefault(path, texture_tint(Path(path)))
        if tint is not None:  # PyBullet draws the texture times the colour: one colour stands for both
            rgba = [rgba[0] * tint[0], rgba[1] * tint[1], rgba[2] * tint[2], rgba[3]]
        shapes.append({**{k: v for k, v in item.items() if k != "mesh_file"}, "mesh": index[path], "rgba": rgba})
    return {**scene, "shapes": shapes, "meshes": meshes}


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def link_poses(world: Any, links: list[Any]) -> list[float | None]:
    """Every drawn link's world position (m) and quaternion (x, y, z, w), 7 numbers a link, flat; None for the links
    of a body removed during the run."""
    client = world.client if world.engine == "pybullet" else None
    out: list[float | None] = []
    for link in links:
        if not world.has_body(link.body):
            out += [None] * 7
            continue
        bid = world.body(link.body)
        if client is None:
            pos, orn = world.pose(bid, link.index)
        elif link.index < 0:
            pos, orn = _base_frame(client, bid)
        else:
            state = client.getLinkState(bid, link.index, computeForwardKinematics=True)
            pos, orn = state[4], state[5]
        out += [round(float(v), 6) for v in (*pos, *orn)]
    return out
