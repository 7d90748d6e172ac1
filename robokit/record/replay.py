"""A record turned into what a 3D viewer draws: each link's world pose at every pose sample, and the visual shapes
fixed to the links (primitives and mesh files), read from a scene rebuilt in DIRECT (:mod:`robokit.record.scene`).

Viewers (the exports to Rerun and MCAP/Foxglove, a page's replay) draw these client-side, from any angle, at no
render cost: one forward kinematics pass per pose sample, no image is rendered here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from robokit.record.format import RunRecord
from robokit.record.scene import Scene, rebuild

GEOMETRY = {2: "sphere", 3: "box", 4: "cylinder", 5: "mesh", 6: "plane", 7: "capsule"}
"""PyBullet's visual geometry type numbers (``GEOM_SPHERE`` ...), by name."""


@dataclass(frozen=True)
class Link:
    """One drawn frame: a body's base (``index == -1``, ``link`` is the base link's name) or one of its links.

    ``path`` is ``body/link``: every frame of a body is a sibling of the others (each carries a world pose)."""

    body: str
    link: str
    index: int

    @property
    def path(self) -> str:
        return f"{self.body}/{self.link}"


@dataclass(frozen=True)
class Shape:
    """A visual shape fixed to a link: ``kind`` (box, sphere, cylinder, capsule, mesh, plane), its ``size``
    (box: full extents, metres; sphere: radius; cylinder/capsule: length, radius; mesh: scale), ``mesh`` (file, or
    ""), ``rgba`` (0..1), and its pose in the link's frame (``position`` metres, ``quaternion`` x, y, z, w)."""

    frame: int
    kind: str
    size: tuple[float, ...]
    mesh: str
    rgba: tuple[float, float, float, float]
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]


@dataclass
class Replay:
    """Everything a viewer needs: ``links``, ``shapes``, sample times ``t`` (N,) and ``poses`` (N, links, 7): each
    link frame's world position (x, y, z, metres) and quaternion (x, y, z, w); NaN once its body was removed."""

    links: list[Link]
    shapes: list[Shape]
    t: np.ndarray
    poses: np.ndarray


def _base_frame(client: Any, bid: int) -> tuple[Any, Any]:
    """The base's URDF link frame (getBasePositionAndOrientation gives its centre of mass)."""
    pos, orn = client.getBasePositionAndOrientation(bid)
    info = client.getDynamicsInfo(bid, -1)
    inv_pos, inv_orn = client.invertTransform(info[3], info[4])
    return client.multiplyTransforms(pos, orn, inv_pos, inv_orn)


def _links(scene: Scene) -> tuple[list[Link], list[Shape]]:
    client, world = scene.world.client, scene.world
    links: list[Link] = []
    shapes: list[Shape] = []
    for name in scene.joints:
        bid = world.body(name)
        frame_of: dict[int, int] = {}
        for s in client.getVisualShapeData(bid):
            index, kind = int(s[1]), GEOMETRY.get(int(s[2]))
            if kind is None:
                continue
            if index not in frame_of:
                link = (client.getBodyInfo(bid)[0].decode() or "base") if index < 0 else \
                    client.getJointInfo(bid, index)[12].decode()
                frame_of[index] = len(links)
                links.append(Link(name, link, index))
            mesh = s[4].decode(errors="replace") if kind == "mesh" else ""
            shapes.append(Shape(frame_of[index], kind, tuple(float(v) for v in s[3]), mesh,
                                tuple(float(v) for v in s[7]), tuple(s[5]), tuple(s[6])))  # type: ignore[arg-type]
    return links, shapes


def _pose_row(scene: Scene, links: list[Link]) -> np.ndarray:
    client, world = scene.world.client, scene.world
    row = np.empty((len(links), 7))
    for k, link in enumerate(links):
        bid = world.body(link.body)
        if link.index < 0:
            pos, orn = _base_frame(client, bid)
        else:
            state = client.getLinkState(bid, link.index, computeForwardKinematics=True)
            pos, orn = state[4], state[5]
        row[k, :3], row[k, 3:] = pos, orn
    return row


def replay_of(rec: RunRecord, every: int = 1) -> Replay:
    """The record's links, shapes and link poses at every ``every``-th pose sample (and the last one).

    Raises:
        UserError: The record has no pose log or its scene cannot be rebuilt here.
    """
    t = rec.poses["t"]
    samples = sorted(set(range(0, len(t), max(1, every))) | ({len(t) - 1} if len(t) else set()))
    with rebuild(rec) as scene:
        links, shapes = _links(scene)
        poses = np.empty((len(samples), len(links), 7))
        for n, i in enumerate(samples):
            scene.set_frame(i)
            poses[n] = _pose_row(scene, links)
            for k, link in enumerate(links):  # a removed body: parked far away by set_frame, drawn nowhere
                base = rec.poses.get(f"base/{link.body}")
                if base is not None and np.isnan(base[i, 0]):
                    poses[n, k] = np.nan
    return Replay(links, shapes, t[samples].astype(float), poses)
