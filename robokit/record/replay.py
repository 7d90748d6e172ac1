"""A record turned into what a 3D viewer draws: each link's world pose at every pose sample, and the visual shapes
fixed to the links (primitives and mesh files), read from a scene rebuilt in DIRECT (:mod:`robokit.record.scene`).

Viewers (the exports to Rerun and MCAP/Foxglove, a page's replay) draw these client-side, from any angle, at no
render cost: one forward kinematics pass per pose sample, no image is rendered here.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robokit.record.format import FRAMES_DIR, RunRecord
from robokit.record.scene import Scene, View, choose_view, rebuild

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
    link frame's world position (x, y, z, metres) and quaternion (x, y, z, w); NaN once its body was removed; and
    ``view``, the camera ``robokit video`` looks through by default (its ``iso`` view of this scene)."""

    links: list[Link]
    shapes: list[Shape]
    t: np.ndarray
    poses: np.ndarray
    view: View | None = None


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
    tints: dict[str, tuple[float, float, float] | None] = {}
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
            rgba = tuple(float(v) for v in s[7])
            if mesh:
                if mesh not in tints:
                    tints[mesh] = texture_tint(Path(mesh))
                tint = tints[mesh]
                if tint is not None:  # PyBullet draws the texture times the colour: one colour stands for both
                    rgba = (rgba[0] * tint[0], rgba[1] * tint[1], rgba[2] * tint[2], rgba[3])
            shapes.append(Shape(frame_of[index], kind, tuple(float(v) for v in s[3]), mesh,
                                rgba, tuple(s[5]), tuple(s[6])))  # type: ignore[arg-type]
    return links, shapes


def texture_tint(mesh: Path) -> tuple[float, float, float] | None:
    """The mean colour (RGB, 0..1) of the texture a Wavefront OBJ's material file names (``mtllib`` ... ``map_Kd``),
    which PyBullet draws the mesh with; None for a mesh without one (or one that cannot be read).

    Viewers draw meshes in one colour, so a textured mesh (the sort scene's table and trays) is drawn in its
    texture's mean colour instead of the white its URDF gives."""
    if mesh.suffix.lower() != ".obj":
        return None
    library = None
    try:
        with mesh.open(encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("mtllib "):
                    library = line.split(None, 1)[1].strip()
                    break
                if line.startswith(("v ", "f ")):  # the material library comes before the geometry
                    break
        if library is None:
            return None
        materials = (mesh.parent / library).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    texture = next((line.split(None, 1)[1].strip() for line in materials
                    if line.strip().startswith("map_Kd ") and len(line.split()) > 1), None)
    if texture is None:
        return None
    import cv2

    image = cv2.imread(str(mesh.parent / texture), cv2.IMREAD_COLOR)
    if image is None:
        return None
    blue, green, red = image.reshape(-1, 3).mean(axis=0) / 255.0
    return float(red), float(green), float(blue)


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
        from robokit.record.video import DEFAULT_SIZE

        view = choose_view(scene, None, DEFAULT_SIZE[0] / DEFAULT_SIZE[1])  # as the video: before any pose is set
        links, shapes = _links(scene)
        poses = np.empty((len(samples), len(links), 7))
        for n, i in enumerate(samples):
            scene.set_frame(i)
            poses[n] = _pose_row(scene, links)
            for k, link in enumerate(links):  # a removed body: parked far away by set_frame, drawn nowhere
                base = rec.poses.get(f"base/{link.body}")
                if base is not None and np.isnan(base[i, 0]):
                    poses[n, k] = np.nan
    return Replay(links, shapes, t[samples].astype(float), poses, view)


# ----------------------------------------------------------------- the page's interactive replay
MESH_BUDGET = 3_000_000
"""Bytes of mesh data (float32 vertices, uint32 triangles) a page embeds at most; past that, boxes stand in."""


def read_obj(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices (n, 3) float32 and triangles (m, 3) uint32 of a Wavefront OBJ file (polygons fanned), or None."""
    verts: list[list[float]] = []
    faces: list[list[int]] = []
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return None
    for line in lines:
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v" and len(parts) >= 4:
            verts.append([float(v) for v in parts[1:4]])
        elif parts[0] == "f" and len(parts) >= 4:
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
            faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    if not verts or not faces:
        return None
    return np.asarray(verts, np.float32), np.asarray(faces, np.uint32)


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode("ascii")


def payload(rec: RunRecord, replay: Replay | None = None) -> dict[str, Any]:
    """What the page's replay script draws: link paths, shapes (meshes as base64 float32/uint32 arrays), the
    sample times and link poses (base64 float32, NaN = removed), and each machine's stays in its states."""
    replay = replay or replay_of(rec)
    meshes: dict[str, int] = {}
    mesh_data: list[dict[str, str]] = []
    spent = 0
    shapes = []
    for s in replay.shapes:
        item: dict[str, Any] = {"frame": s.frame, "kind": s.kind, "size": s.size, "rgba": s.rgba,
                                "position": s.position, "quaternion": s.quaternion}
        if s.kind == "mesh":
            if s.mesh not in meshes:
                got = read_obj(Path(s.mesh)) if s.mesh.lower().endswith(".obj") else None
                if got is None or spent + got[0].nbytes + got[1].nbytes > MESH_BUDGET:
                    continue
                spent += got[0].nbytes + got[1].nbytes
                meshes[s.mesh] = len(mesh_data)
                mesh_data.append({"vertices": _b64(got[0]), "triangles": _b64(got[1])})
            item["mesh"] = meshes[s.mesh]
        shapes.append(item)
    spans = rec.spans()
    return {"links": [link.path for link in replay.links], "shapes": shapes, "meshes": mesh_data,
            "frames": _camera_frames(rec),
            "view": None if replay.view is None else {"eye": replay.view.eye, "target": replay.view.target,
                                                      "up": replay.view.up, "fov": replay.view.fov},
            "t": _b64(replay.t.astype(np.float32)), "poses": _b64(replay.poses.astype(np.float32)),
            "duration": float(max(rec.sim_time, float(replay.t[-1]) if len(replay.t) else 0.0)),
            "machines": [{"name": name, "spans": [[s.state, s.start, s.end] for s in stays]}
                         for name, stays in spans.items()]}


def camera_frames(rec: RunRecord) -> list[tuple[str, float, Path]]:
    """Saved colour frames ``(camera, sim time, png)``, in time order (``frames/<camera>_<tick>_rgb.png``)."""
    folder, step = rec.folder / FRAMES_DIR, float(rec.header.get("time_step") or 1 / 240)
    out = []
    for png in sorted(folder.glob("*_rgb.png")) if folder.is_dir() else []:
        camera, tick, _ = png.name.rsplit("_", 2)
        out.append((camera, int(tick) * step, png))
    return sorted(out, key=lambda item: item[1])


FRAME_BUDGET = 1_000_000
"""Bytes of saved camera frames (PNG) a page embeds at most, earliest first."""


def _camera_frames(rec: RunRecord) -> list[dict[str, Any]]:
    """The colour frames the cameras saved (``--save-frames``), as ``{camera, t, png}`` (a data URI), in time order."""
    out: list[dict[str, Any]] = []
    spent = 0
    for camera, t, png in camera_frames(rec):
        data = png.read_bytes()
        if spent + len(data) > FRAME_BUDGET:
            break
        spent += len(data)
        out.append({"camera": camera, "t": t,
                    "png": "data:image/png;base64," + base64.b64encode(data).decode("ascii")})
    return out


def viewer_path() -> Path | None:
    """The replay's browser viewer: three.js with its orbit controls as one script (``robokit/data/three.min.js``,
    made from the pinned npm package by ``tools/fetch-three.sh``); None if the file is missing."""
    path = Path(__file__).resolve().parent.parent / "data" / "three.min.js"
    return path if path.is_file() else None


def viewer_script() -> str | None:
    """The text of :func:`viewer_path`'s file, or None."""
    path = viewer_path()
    return path.read_text(encoding="utf-8") if path is not None else None


REPLAY_CSS = """
#rk-replay { position: relative; } #rk-pane { width: 100%; height: 480px; position: relative; overflow: hidden; }
.rk-bar { display: flex; gap: 8px; align-items: center; margin: 6px 0; } #rk-time { flex: 1; }
.rk-row { display: flex; align-items: center; gap: 8px; font-size: 11px; margin: 2px 0; }
.rk-name { width: 90px; text-align: right; color: #555; }
.rk-track { position: relative; flex: 1; height: 18px; background: #f4f4f4; }
.rk-span { position: absolute; top: 0; height: 18px; overflow: hidden; white-space: nowrap; cursor: pointer;
           font-size: 10px; line-height: 18px; padding-left: 2px; box-sizing: border-box;
           border-right: 1px solid #fff; }
#rk-hover { position: absolute; left: 8px; top: 8px; background: rgba(0,0,0,.6); color: #fff; font-size: 12px;
            padding: 2px 6px; border-radius: 4px; display: none; pointer-events: none; z-index: 2; }
#rk-seen { position: absolute; left: 8px; bottom: 8px; margin: 0; display: none; z-index: 2; background: #fff;
           padding: 3px; font-size: 11px; } #rk-seen img { display: block; max-width: 220px; }
.rk-cursor { position: absolute; top: -2px; width: 2px; height: 22px; background: #c62828; pointer-events: none; }
"""
"""The replay's styles (the run page offline and the server's run page)."""

REPLAY_SCRIPT = Path(__file__).resolve().parent.parent / "data" / "replay.js"
"""robokit's replay script: draws ``RK_REPLAY`` (a :func:`payload`) with three.js (:func:`viewer_path`)."""


def replay_markup(attrs: str = "") -> str:
    """The replay's elements: a pane for the canvas, play/pause, speed, a time scrubber and the state timeline.
    ``attrs`` (already escaped) go on the outer ``div`` (the server's page names its data and script there)."""
    controls = ("<div class='rk-bar'><button id='rk-play' type='button'>play</button>"
                "<select id='rk-speed' aria-label='speed'><option value='0.25'>0.25x</option>"
                "<option value='0.5'>0.5x</option><option value='1' selected>1x</option>"
                "<option value='2'>2x</option><option value='4'>4x</option></select>"
                "<input id='rk-time' type='range' min='0' max='1000' value='0' aria-label='time'>"
                "<span id='rk-clock' class='meta'>t = 0.00 s</span></div>"
                "<div id='rk-states'></div>")
    return (f"<div id='rk-replay'{attrs}><div id='rk-pane'><div id='rk-hover'></div><figure id='rk-seen'>"
            f"<figcaption></figcaption></figure></div>{controls}</div>")


def replay_html(rec: RunRecord, replay: Replay | None = None) -> str | None:
    """The replay for a page that opens offline: :func:`replay_markup`, then the viewer (three.js), the data and the
    script inline; None if the viewer's file is missing (the page then says so)."""
    viewer = viewer_script()
    if viewer is None:
        return None
    data = json.dumps(payload(rec, replay), separators=(",", ":")).replace("</", "<\\/")
    script = REPLAY_SCRIPT.read_text(encoding="utf-8")
    return (replay_markup() +
            f"<script>{viewer}</script><script>var RK_REPLAY = {data};</script><script>{script}</script>")
