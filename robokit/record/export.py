"""``robokit export``: a run's record for the viewers robotics people use — Rerun (``.rrd``) and Foxglove (``.mcap``).

Both carry the same content, on sim time: every link's world transform at each pose sample, the bodies' visual
shapes fixed to their links (boxes, spheres, cylinders, capsules, meshes by file path), a laser scan per lidar
re-cast on the recorded poses, the saved camera frames, and each state change as a log message.

- Rerun: entity ``world/<body>[/<link>]`` with a ``Transform3D`` per sample and its shapes (``Boxes3D``,
  ``Ellipsoids3D``, ``Cylinders3D``, ``Asset3D``) logged once; ``world/lidar/<name>`` points; ``camera/<name>``
  encoded images; ``states/<machine>`` text logs. Needs the ``rerun`` extra (``rerun-sdk``), imported only here.
- MCAP (the ``mcap`` package; JSON messages with the Foxglove schemas' names and fields): ``/tf``
  (``foxglove.FrameTransforms``), ``/scene`` (``foxglove.SceneUpdate``, frame-locked entities), ``/lidar/<name>``
  (``foxglove.LaserScan``), ``/camera/<name>`` (``foxglove.CompressedImage``), ``/states``
  (``foxglove.Log``).
"""

from __future__ import annotations

import base64
import functools
import json
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from robokit.extras import require
from robokit.record.atomic import atomic_output
from robokit.record.format import RunRecord
from robokit.record.replay import Replay, Shape, camera_frames, read_obj, replay_of


def _ns(t: float) -> int:
    return int(round(t * 1e9))


def _stamp(t: float) -> dict[str, int]:
    ns = _ns(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def lidar_scans(rec: RunRecord, every: int = 1) -> Iterator[tuple[str, float, dict[str, Any]]]:
    """``(lidar name, sim time, scan)`` for every lidar sensor at every ``every``-th pose sample, re-cast on the
    recorded poses without noise; a scan: ``origin`` (m, world), ``quaternion`` (x, y, z, w, world), ``angles``
    (rad, counter-clockwise from the sensor's +x) and ``ranges`` (m, +inf = no return)."""
    from robokit.record.plots import cast_scan
    from robokit.record.scene import rebuild

    lidars = {n: s for n, s in rec.header["config"].get("sensors", {}).items()
              if isinstance(s, dict) and s.get("type") == "lidar"}
    if not lidars:
        return
    t = rec.poses["t"]
    with rebuild(rec) as scene:
        world, client = scene.world, scene.world.client
        for i in range(0, len(t), max(1, every)):
            scene.set_frame(i)
            for name, spec in lidars.items():
                robot, link = str(spec.get("robot", "robot")), str(spec.get("link", "lidar_link"))
                pos, orn = world.pose(robot, world.link(robot, link))
                yaw = client.getQuaternionFromEuler([0, 0, math.radians(float(spec.get("yaw_offset_deg", 0.0)))])
                origin, quat = client.multiplyTransforms(pos, orn, list(spec.get("offset", (0, 0, 0))), yaw)
                angles, ranges = cast_scan(world, spec)
                yield name, float(t[i]), {"origin": origin, "quaternion": quat, "angles": angles, "ranges": ranges}


def state_changes(rec: RunRecord) -> list[tuple[float, str, str]]:
    """``(sim time, machine, message)`` for each machine's initial state and every transition."""
    out = [(0.0, m["name"], f"{m['name']}: start in {m['initial']}") for m in rec.header.get("machines", [])]
    for e in rec.events:
        if e.get("kind") == "transition":
            out.append((float(e["t"]), str(e["machine"]), f"{e['machine']}: {e['source_state']} -> "
                        f"{e['dest_state']} ({e['trigger']})"))
    return out


# ----------------------------------------------------------------- meshes, embedded
MEDIA_TYPES = {".stl": "model/stl", ".glb": "model/gltf-binary", ".gltf": "model/gltf+json",
               ".dae": "model/vnd.collada+xml"}
"""Mesh files embedded as they are, by suffix (Wavefront OBJ is converted: its materials live in other files)."""


@functools.lru_cache(maxsize=256)
def mesh_model(path: str) -> tuple[bytes, str] | None:
    """A mesh file's geometry as bytes to embed and their media type: a Wavefront OBJ as binary STL (its triangles;
    the colour comes from the shape), other formats Foxglove and Rerun read as they are; None if unreadable."""
    mesh = Path(path)
    if mesh.suffix.lower() == ".obj":
        got = read_obj(mesh)
        return None if got is None else (stl_bytes(*got), "model/stl")
    media = MEDIA_TYPES.get(mesh.suffix.lower())
    try:
        return (mesh.read_bytes(), media) if media is not None else None
    except OSError:
        return None


def stl_bytes(vertices: np.ndarray, triangles: np.ndarray) -> bytes:
    """Binary STL of a triangle mesh (vertices (n, 3) in the mesh's units, triangles (m, 3) vertex indices)."""
    corners = vertices[triangles].astype(np.float32)  # (m, 3 corners, 3)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    rows = np.zeros(len(triangles), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]))
    rows["n"], rows["v"] = normals, corners
    return b"robokit mesh".ljust(80, b" ") + np.uint32(len(triangles)).tobytes() + rows.tobytes()


def read_stl(data: bytes) -> np.ndarray:
    """The triangles (m, 3 corners, 3) of a binary STL (what :func:`stl_bytes` writes)."""
    count = int(np.frombuffer(data[80:84], "<u4")[0])
    rows = np.frombuffer(data[84:84 + 50 * count], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                                    ("attr", "<u2")]))
    return rows["v"].copy()


# ----------------------------------------------------------------- Rerun
def _rerun_shape(rr: Any, shape: Shape) -> Any:
    colour = [int(round(255 * c)) for c in shape.rgba]
    centre, quat = [list(shape.position)], [rr.Quaternion(xyzw=list(shape.quaternion))]
    if shape.kind == "box":
        return rr.Boxes3D(half_sizes=[[s / 2 for s in shape.size[:3]]], centers=centre, quaternions=quat,
                          colors=[colour], fill_mode="solid")
    if shape.kind == "sphere":
        return rr.Ellipsoids3D(half_sizes=[[shape.size[0]] * 3], centers=centre, quaternions=quat, colors=[colour],
                               fill_mode="solid")
    if shape.kind in ("cylinder", "capsule"):
        return rr.Cylinders3D(lengths=[shape.size[0]], radii=[shape.size[1]], centers=centre, quaternions=quat,
                              colors=[colour], fill_mode="solid")
    if shape.kind == "mesh":
        model = mesh_model(shape.mesh)
        if model is not None:  # the bytes themselves: the file travels without the exporting machine's paths
            return rr.Asset3D(contents=model[0], media_type=model[1], albedo_factor=colour)
    return None


def export_rerun(rec: RunRecord, out: Path, replay: Replay | None = None) -> dict[str, int]:
    """Write the record as a Rerun recording (``.rrd``). Returns counts: shapes, transforms, scans, images, logs.

    Raises:
        UserError: rerun-sdk is not installed.
    """
    require("rerun", "robokit export --rerun", ("rerun",))
    os.environ.setdefault("RUST_LOG", "off")  # Rerun's own log lines (read when it loads): a failure is said once
    import rerun as rr
    import rerun.blueprint as rrb

    from robokit.record.atomic import OutputFailed

    replay = replay or replay_of(rec)
    with atomic_output(out) as tmp:
        stream = rr.RecordingStream("robokit", recording_id=rec.run_id)
        rr.set_log_time_enabled(False, recording=stream)  # one timeline, the run's: "sim" (sim seconds)
        # Rerun encodes into memory and robokit writes the bytes: Rerun's own file writer, under a file-size limit,
        # can block for ever instead of failing; a write of ours fails at once (OSError -> OutputFailed)
        encoded = rr.binary_stream(recording=stream)
        stream.send_blueprint(rrb.Blueprint(rrb.TimePanel(timeline="sim")), make_active=False, make_default=True)
        counts = _log_rerun(rr, stream, rec, replay)
        try:
            data = encoded.read(flush=True, flush_timeout_sec=600.0)
        except RuntimeError as exc:  # Rerun's encoder stopped
            raise OutputFailed(out, f"Rerun could not encode the recording ({exc})") from None
        try:
            with open(tmp, "wb") as fh:
                fh.write(data or b"")
        except OSError as exc:  # a full disk, a file-size limit
            raise OutputFailed(out, f"{exc.strerror or exc}{_write_limits(out)}") from None
        _check_rrd(tmp, out, counts["transforms"])
    return counts


def _write_limits(out: Path) -> str:
    """What may have stopped a write: a file-size limit set for this process, or a disk nearly full."""
    import resource
    import shutil

    soft, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if soft != resource.RLIM_INFINITY:
        return f"; a file-size limit of {soft} bytes is set"
    free = shutil.disk_usage(out.parent).free
    return f"; {free} bytes are free on its disk" if free < 16 << 20 else ""


def _check_rrd(path: Path, out: Path, transforms: int) -> None:
    """Read the recording back (Rerun's own reader) before it takes its name: every transform logged is there."""
    import rerun.chunk

    from robokit.record.atomic import OutputFailed

    try:
        found = sum(chunk.num_rows for chunk in rerun.chunk.RrdReader(path).store().stream()
                    if "Transform3D:translation" in chunk.to_record_batch().schema.names)
    except Exception as exc:  # noqa: BLE001 - whatever the reader says, the file is not whole
        raise OutputFailed(out, f"the recording written cannot be read back: {exc}") from None
    if found != transforms:
        raise OutputFailed(out, f"the recording written holds {found} of {transforms} transforms")


def _log_rerun(rr: Any, stream: Any, rec: RunRecord, replay: Replay) -> dict[str, int]:
    counts = {"shapes": 0, "transforms": 0, "scans": 0, "images": 0, "logs": 0}
    stream.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for k, link in enumerate(replay.links):
        for n, shape in enumerate(s for s in replay.shapes if s.frame == k):
            drawn = _rerun_shape(rr, shape)
            if drawn is not None:
                stream.log(f"world/{link.path}/shape_{n}", drawn, static=True)
                counts["shapes"] += 1
    for n, t in enumerate(replay.t):
        stream.set_time("sim", duration=float(t))
        for k, link in enumerate(replay.links):
            row = replay.poses[n, k]
            if not np.isnan(row[0]):
                stream.log(f"world/{link.path}", rr.Transform3D(translation=row[:3], quaternion=rr.Quaternion(
                    xyzw=row[3:])))
                counts["transforms"] += 1
    for name, t, scan in lidar_scans(rec):
        stream.set_time("sim", duration=t)
        hit = np.isfinite(scan["ranges"])
        rot = np.asarray(rr_matrix(scan["quaternion"]))
        local = np.stack([np.cos(scan["angles"]), np.sin(scan["angles"]), np.zeros_like(scan["angles"])]).T
        points = np.asarray(scan["origin"]) + (local[hit] * scan["ranges"][hit, None]) @ rot.T
        stream.log(f"world/lidar/{name}", rr.Points3D(points, radii=0.01, colors=[[230, 40, 40]]))
        counts["scans"] += 1
    for camera, t, png in camera_frames(rec):
        stream.set_time("sim", duration=t)
        stream.log(f"camera/{camera}", rr.EncodedImage(contents=png.read_bytes(), media_type="image/png"))
        counts["images"] += 1
    for t, machine, message in state_changes(rec):
        stream.set_time("sim", duration=t)
        stream.log(f"states/{machine}", rr.TextLog(message, level="INFO"))
        counts["logs"] += 1
    return counts


def rr_matrix(q: Any) -> list[list[float]]:
    """3x3 rotation matrix of a quaternion (x, y, z, w)."""
    x, y, z, w = (float(v) for v in q)
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


# ----------------------------------------------------------------- MCAP (Foxglove schemas, JSON encoding)
_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}
_PRIM = {"type": "array", "items": {"type": "object", "properties": {"pose": _POSE, "size": _VEC3, "color": _COLOR}}}
_MODEL = {"type": "array", "items": {"type": "object", "properties": {
    "pose": _POSE, "scale": _VEC3, "color": _COLOR, "override_color": {"type": "boolean"}, "url": {"type": "string"},
    "media_type": {"type": "string"}, "data": {"type": "string", "contentEncoding": "base64"}}}}
SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.FrameTransforms": {"transforms": {"type": "array", "items": {"type": "object", "properties": {
        "timestamp": _TIME, "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
        "translation": _VEC3, "rotation": _QUAT}}}},
    "foxglove.SceneUpdate": {"deletions": {"type": "array"}, "entities": {"type": "array", "items": {
        "type": "object", "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"}, "id": {"type": "string"}, "lifetime": _TIME,
            "frame_locked": {"type": "boolean"}, "cubes": _PRIM, "spheres": _PRIM, "cylinders": _PRIM,
            "models": _MODEL}}}},
    "foxglove.LaserScan": {"timestamp": _TIME, "frame_id": {"type": "string"}, "pose": _POSE,
                           "start_angle": {"type": "number"}, "end_angle": {"type": "number"},
                           "ranges": {"type": "array", "items": {"type": "number"}},
                           "intensities": {"type": "array", "items": {"type": "number"}}},
    "foxglove.CompressedImage": {"timestamp": _TIME, "frame_id": {"type": "string"},
                                 "data": {"type": "string", "contentEncoding": "base64"}, "format": {"type": "string"}},
    "foxglove.Log": {"timestamp": _TIME, "level": {"type": "integer"}, "message": {"type": "string"},
                     "name": {"type": "string"}, "file": {"type": "string"}, "line": {"type": "integer"}},
}
"""JSON schemas for the Foxglove message types written, with Foxglove's names and field names (the fields used)."""
LOG_INFO = 2
"""``foxglove.Log`` level INFO."""


def _pose(position: Any, quaternion: Any) -> dict[str, Any]:
    return {"position": dict(zip("xyz", map(float, position), strict=True)),
            "orientation": dict(zip("xyzw", map(float, quaternion), strict=True))}


def _entity(replay: Replay, k: int) -> dict[str, Any]:
    """One link's shapes as a frame-locked scene entity in the link's frame."""
    prims: dict[str, list[dict[str, Any]]] = {"cubes": [], "spheres": [], "cylinders": [], "models": []}
    for s in (s for s in replay.shapes if s.frame == k):
        colour = dict(zip("rgba", s.rgba, strict=True))
        pose = _pose(s.position, s.quaternion)
        if s.kind == "box":
            prims["cubes"].append({"pose": pose, "size": dict(zip("xyz", s.size[:3], strict=True)), "color": colour})
        elif s.kind == "sphere":
            prims["spheres"].append({"pose": pose, "size": dict.fromkeys("xyz", 2 * s.size[0]), "color": colour})
        elif s.kind in ("cylinder", "capsule"):
            d = 2 * s.size[1]
            prims["cylinders"].append({"pose": pose, "size": {"x": d, "y": d, "z": s.size[0]}, "color": colour,
                                       "bottom_scale": 1.0, "top_scale": 1.0})
        elif s.kind == "mesh":
            model = mesh_model(s.mesh)
            if model is not None:  # embedded: no URL into the exporting machine's files
                prims["models"].append({"pose": pose, "scale": dict(zip("xyz", s.size[:3], strict=True)),
                                        "color": colour, "override_color": model[1] == "model/stl", "url": "",
                                        "media_type": model[1], "data": base64.b64encode(model[0]).decode("ascii")})
    return {"timestamp": _stamp(0.0), "frame_id": replay.links[k].path, "id": replay.links[k].path,
            "lifetime": _stamp(0.0), "frame_locked": True, "metadata": [], "arrows": [], "lines": [],
            "triangles": [], "texts": [], **prims}


def export_mcap(rec: RunRecord, out: Path, replay: Replay | None = None) -> dict[str, int]:
    """Write the record as MCAP with Foxglove's message schemas (JSON). Returns messages per topic.

    Raises:
        UserError: the mcap package is not installed.
    """
    require("rerun", "robokit export --mcap", ("mcap",))
    from mcap.writer import Writer

    replay = replay or replay_of(rec)
    counts: dict[str, int] = {}
    with atomic_output(out) as tmp, tmp.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="robokit")
        schema_ids = {name: writer.register_schema(name=name, encoding="jsonschema", data=json.dumps(
            {"title": name, "type": "object", "properties": props}).encode()) for name, props in SCHEMAS.items()}
        channels: dict[str, int] = {}

        def send(topic: str, schema: str, t: float, message: dict[str, Any]) -> None:
            if topic not in channels:
                channels[topic] = writer.register_channel(topic=topic, message_encoding="json",
                                                          schema_id=schema_ids[schema])
            writer.add_message(channels[topic], log_time=_ns(t), publish_time=_ns(t),
                               data=json.dumps(message, allow_nan=False).encode())
            counts[topic] = counts.get(topic, 0) + 1

        send("/scene", "foxglove.SceneUpdate", 0.0,
             {"deletions": [], "entities": [_entity(replay, k) for k in range(len(replay.links))]})
        for n, t in enumerate(replay.t):
            tfs = [{"timestamp": _stamp(float(t)), "parent_frame_id": "world", "child_frame_id": link.path,
                    **dict(zip(("translation", "rotation"), _pose(row[:3], row[3:]).values(), strict=True))}
                   for link, row in zip(replay.links, replay.poses[n], strict=True) if not np.isnan(row[0])]
            send("/tf", "foxglove.FrameTransforms", float(t), {"transforms": tfs})
        for name, t, scan in lidar_scans(rec):
            angles, ranges = scan["angles"], scan["ranges"]
            send(f"/lidar/{name}", "foxglove.LaserScan", t, {
                "timestamp": _stamp(t), "frame_id": "world", "pose": _pose(scan["origin"], scan["quaternion"]),
                "start_angle": float(angles[0]), "end_angle": float(angles[-1]),
                "ranges": [float(r) if np.isfinite(r) else 0.0 for r in ranges], "intensities": []})
        for camera, t, png in camera_frames(rec):
            send(f"/camera/{camera}", "foxglove.CompressedImage", t, {
                "timestamp": _stamp(t), "frame_id": camera, "format": "png",
                "data": base64.b64encode(png.read_bytes()).decode("ascii")})
        for t, machine, message in state_changes(rec):
            send("/states", "foxglove.Log", t, {"timestamp": _stamp(t), "level": LOG_INFO, "message": message,
                                                "name": machine, "file": "", "line": 0})
        writer.finish()
    return counts
