"""Every row of an export compared with the record it came from: MCAP's transforms, scans and logs.

A diffbot starts turned (143 degrees: no identity, no half turn) and drives an arc with its wheels spinning, a turned
wall (37 degrees) within its lidar's reach; the run is recorded and exported with ``robokit export --mcap``. Each
``/tf`` message is checked against the pose log sample of the same index -- its timestamp, and every link's world pose
worked out here from the recorded base centre of mass, the URDF's inertial origin, joint origins and axes, and the
recorded joint angles -- and each ``/states`` log line against the trace's transition records; each ``/lidar`` scan's
pose is the lidar link's frame of that sample, and each of its ranges the distance along its ray to the wall, met in
closed form. Each link's entity in ``/scene`` carries the URDF's visual (shape, size, colour, its origin in the link
frame); the record itself: a pose sample every ``round(240 / 30)`` ticks from tick 0 to the last, ``t = tick x
time_step``, and the trace's ``end`` record the result's.
"""

from __future__ import annotations

import base64
import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pybullet_data
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import rodrigues, rotation

from robokit.cli import main
from robokit.record.format import find_run

ROOT = Path(__file__).resolve().parents[1]
DIFFBOT = ROOT / "robokit" / "data" / "robots" / "diffbot.urdf"
YAW = math.radians(143.0)
SCENE = f"""
[world]
max_time = 0.75

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[robots.robot]
urdf = "{DIFFBOT}"
position = [0.3, -0.2, 0.06]
rpy_deg = [0, 0, 143]

[bodies.wall]
shape = "box"
size = [0.3, 2.0, 0.6]
mass = 0
position = [1.2, -0.8, 0.3]
rpy_deg = [0, 0, 37]
rgba = [0.2, 0.7, 0.3, 1]

[bodies.post]
shape = "box"
size = [0.1, 0.1, 0.6]
mass = 0
position = [0.3, -0.9, 0.3]

[[events]]
at = 0.4
type = "remove"
body = "post"

[sensors.scan]
type = "lidar"
rate_hz = 10
rays = 36
range_max = 3.0

[actuators.drive]
type = "diff_drive"

[behaviour]
type = "go_to_goal"
goal = [-1.43, 0.8]
"""


def frame(p: Any, r: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = r, p
    return out


def numbers(text: str | None) -> list[float]:
    return [float(v) for v in (text or "0 0 0").split()]


def urdf() -> tuple[np.ndarray, dict[str, dict[str, Any]]]:
    """The base's inertial origin, and per child link its joint's name, type, origin (4x4) and axis."""
    root = ET.parse(DIFFBOT).getroot()
    base = next(link for link in root.iter("link") if link.get("name") == "base_link")
    origin = base.find("inertial/origin")
    inertial = np.array(numbers(origin.get("xyz") if origin is not None else None))
    joints = {}
    for j in root.iter("joint"):
        o, a = j.find("origin"), j.find("axis")
        r, p, y = numbers(o.get("rpy") if o is not None else None)
        joints[j.find("child").get("link")] = {  # type: ignore[union-attr]
            "name": j.get("name"), "type": j.get("type"), "axis": numbers(a.get("xyz") if a is not None else "1 0 0"),
            "origin": frame(numbers(o.get("xyz") if o is not None else None),
                            rodrigues([0, 0, 1], y) @ rodrigues([0, 1, 0], p) @ rodrigues([1, 0, 0], r))}
    return inertial, joints


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, list[tuple[int, dict]]]]:
    from mcap.reader import make_reader

    folder = tmp_path_factory.mktemp("export")
    (folder / "scene.toml").write_text(SCENE)
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["run", "scene.toml", "--quiet"]) in (0, 1)  # the goal is out of reach in 0.75 s: fine
    finally:
        os.chdir(cwd)
    record = find_run("last", folder / "results").folder
    out = folder / "run.mcap"
    assert main(["export", str(record), "--mcap", str(out)]) == 0
    messages: dict[str, list[tuple[int, dict]]] = {}
    with out.open("rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            messages.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    return record, messages


def test_every_transform_is_the_recorded_sample_composed_with_the_urdf(exported: Any) -> None:
    record, messages = exported
    poses = np.load(record / "poses.npz")
    t, base, joints = poses["t"], poses["base/robot"], poses["joints/robot"]
    inertial, chain = urdf()
    order = [j["name"] for j in sorted(chain.values(), key=lambda j: list(chain.values()).index(j))]
    tf = messages["/tf"]
    assert len(tf) == len(t) and len(t) > 10
    turned = 0.0
    for i, (stamp, msg) in enumerate(tf):
        assert stamp == round(float(t[i]) * 1e9)
        got = {x["child_frame_id"]: x for x in msg["transforms"]}
        for x in msg["transforms"]:
            assert x["timestamp"] == {"sec": stamp // 10**9, "nsec": stamp % 10**9}
        com = frame(base[i, :3], rotation(base[i, 3:]))
        link = com @ frame(-inertial, np.eye(3))  # the link frame seen from the centre of mass
        expected = {"robot/base_link": link}
        q = dict(zip(order, joints[i], strict=False))
        for child, j in chain.items():
            motion = rodrigues(j["axis"], float(q[j["name"]])) if j["type"] == "continuous" else np.eye(3)
            expected[f"robot/{child}"] = link @ j["origin"] @ frame(np.zeros(3), motion)
        for path, want in expected.items():
            tr, rq = got[path]["translation"], got[path]["rotation"]
            assert np.allclose([tr["x"], tr["y"], tr["z"]], want[:3, 3], atol=2e-4), (i, path)
            r = rotation([rq["x"], rq["y"], rq["z"], rq["w"]])
            assert np.degrees(math.acos(max(-1.0, min(1.0, (np.trace(r.T @ want[:3, :3]) - 1) / 2)))) < 0.05, (i, path)
        turned = math.atan2(link[1, 0], link[0, 0])
        if i == 0:  # it starts where the config put it: turned 143 degrees
            assert abs(math.remainder(turned - YAW, 2 * math.pi)) < 0.01
    assert abs(math.remainder(turned - YAW, 2 * math.pi)) > 0.05  # and it turned on the way


def test_every_log_line_is_a_transition_of_the_trace_at_its_time(exported: Any) -> None:
    record, messages = exported
    lines = (record / "trace.jsonl").read_text().splitlines()
    header, events = json.loads(lines[0]), [json.loads(x) for x in lines[1:]]
    want = [(0, f"{m['name']}: start in {m['initial']}") for m in header["machines"]]
    want += [(round(e["t"] * 1e9), f"{e['machine']}: {e['source_state']} -> {e['dest_state']} ({e['trigger']})")
             for e in events if e["kind"] == "transition"]
    got = [(stamp, msg["message"]) for stamp, msg in messages["/states"]]
    assert got == want and len(want) > 1


def test_every_scan_sits_on_the_lidar_link_of_its_sample(exported: Any) -> None:
    record, messages = exported
    poses = np.load(record / "poses.npz")
    t = [round(float(v) * 1e9) for v in poses["t"]]
    tf = {stamp: {x["child_frame_id"]: x for x in msg["transforms"]} for stamp, msg in messages["/tf"]}
    scans = messages["/lidar/scan"]
    assert len(scans) == len(t)
    for stamp, scan in scans:
        lidar = tf[stamp]["robot/lidar_link"]
        p, o = scan["pose"]["position"], scan["pose"]["orientation"]
        assert [p[k] for k in "xyz"] == pytest.approx([lidar["translation"][k] for k in "xyz"], abs=1e-4)
        assert abs(float(np.dot([o[k] for k in "xyzw"], [lidar["rotation"][k] for k in "xyzw"]))) == \
            pytest.approx(1.0, abs=1e-6)
        assert scan["timestamp"] == {"sec": stamp // 10**9, "nsec": stamp % 10**9}


WALL: dict[str, Any] = {"centre": np.array([1.2, -0.8, 0.3]), "half": np.array([0.15, 1.0, 0.3]),
                        "yaw": math.radians(37.0)}


POST: dict[str, Any] = {"centre": np.array([0.3, -0.9, 0.3]), "half": np.array([0.05, 0.05, 0.3]), "yaw": 0.0}


def box_distance(box: dict[str, Any], origin: np.ndarray, direction: np.ndarray) -> float | None:
    """Where a ray first meets a box (slabs in the box's own frame), or None."""
    r = rodrigues([0, 0, 1], box["yaw"]) if box["yaw"] else np.eye(3)
    o, d = r.T @ (origin - box["centre"]), r.T @ direction
    near, far = -math.inf, math.inf
    for k in range(3):
        if abs(d[k]) < 1e-12:
            if abs(o[k]) > box["half"][k]:
                return None
            continue
        a, b = sorted(((-box["half"][k] - o[k]) / d[k], (box["half"][k] - o[k]) / d[k]))
        near, far = max(near, a), min(far, b)
    return near if near <= far and near >= 0 else None


def post_present(record: Path) -> dict[int, bool]:
    """Per sample time (ns), whether the post was still in the world (its pose log row is not NaN)."""
    poses = np.load(record / "poses.npz")
    return {round(float(t) * 1e9): not np.isnan(row[0]) for t, row in zip(poses["t"], poses["base/post"], strict=True)}


def test_the_post_is_removed_at_its_event_and_drawn_until_then(exported: Any) -> None:
    """The pose log's rows of a removed body are NaN from the first sample after its removal; /tf names it
    exactly while it stands."""
    record, messages = exported
    present = post_present(record)
    stamps = sorted(present)
    gone = [s for s in stamps if not present[s]]
    assert gone and gone == stamps[len(stamps) - len(gone):]  # NaN from one sample on, to the end
    assert 0.4e9 <= gone[0] <= 0.4e9 + 1e9 / 30 + 1  # the first sample at or after the removal at 0.4 s
    for stamp, msg in messages["/tf"]:
        posts = [x for x in msg["transforms"] if x["child_frame_id"].startswith("post/")]
        assert len(posts) == present[stamp], stamp
        for x in posts:
            assert [x["translation"][k] for k in "xyz"] == pytest.approx(list(POST["centre"]), abs=1e-6)


def test_every_range_of_every_scan_is_the_distance_to_the_wall_along_its_ray(exported: Any) -> None:
    """36 rays over 360 degrees from -180, in the scan's frame; 0 where the ray meets nothing within 3 m; the post
    stops rays until it is removed."""
    record, messages = exported
    present = post_present(record)
    hits = post_hits = 0
    for stamp, scan in messages["/lidar/scan"]:
        boxes = [WALL, POST] if present[stamp] else [WALL]  # a removed post stops no ray
        p, o = scan["pose"]["position"], scan["pose"]["orientation"]
        origin, frame_rot = np.array([p[k] for k in "xyz"]), rotation([o[k] for k in "xyzw"])
        ranges = scan["ranges"]
        assert len(ranges) == 36
        assert scan["start_angle"] == pytest.approx(-math.pi) and scan["end_angle"] == pytest.approx(math.pi * 34 / 36)
        for k, got in enumerate(ranges):
            seen = []
            for nudge in (-1e-3, 0.0, 1e-3):  # a ray that grazes an edge is left out
                a = -math.pi + k * 2 * math.pi / 36 + nudge
                met = [box_distance(b, origin, frame_rot @ np.array([math.cos(a), math.sin(a), 0.0])) for b in boxes]
                d = min((x for x in met if x is not None), default=None)
                post_hits += len(boxes) == 2 and met[1] is not None and d == met[1] and d < 3.0 and nudge == 0.0
                seen.append(0.0 if d is None or d > 3.0 or d < 0.05 else d)
            if max(seen) - min(seen) > 0.01:
                continue
            assert got == pytest.approx(seen[1], abs=2e-3), (k, got, seen)
            hits += got > 0
    assert hits > len(messages["/lidar/scan"])  # the wall is in reach, several rays a scan
    assert post_hits >= sum(present.values()) // 2  # and the post, while it stands (between two rays at times)


def test_the_wall_stands_where_the_config_put_it_in_every_transform(exported: Any) -> None:
    _, messages = exported
    want = rodrigues([0, 0, 1], WALL["yaw"])
    for _, msg in messages["/tf"]:
        [wall] = [x for x in msg["transforms"] if x["child_frame_id"].startswith("wall/")]
        tr, rq = wall["translation"], wall["rotation"]
        assert [tr[k] for k in "xyz"] == pytest.approx(list(WALL["centre"]), abs=1e-6)
        assert np.allclose(rotation([rq[k] for k in "xyzw"]), want, atol=1e-6)


def urdf_visuals() -> dict[str, dict[str, Any]]:
    """Per link with a visual: its geometry, colour (by material name) and origin, read from the URDF."""
    root = ET.parse(DIFFBOT).getroot()
    colours = {m.get("name"): numbers(m.find("color").get("rgba")) for m in root.findall("material")}  # type: ignore[union-attr]
    out = {}
    for link in root.iter("link"):
        visual = link.find("visual")
        if visual is None:
            continue
        geometry = visual.find("geometry")[0]  # type: ignore[index]
        origin = visual.find("origin")
        out[link.get("name")] = {"kind": geometry.tag, **{k: numbers(v) for k, v in geometry.attrib.items()},
                                 "rgba": colours[visual.find("material").get("name")],  # type: ignore[union-attr]
                                 "xyz": numbers(origin.get("xyz") if origin is not None else None)}
    return out  # type: ignore[return-value]


def test_every_links_scene_entity_carries_its_urdf_visual(exported: Any) -> None:
    _, messages = exported
    [(stamp, scene)] = messages["/scene"]
    entities = {e["id"]: e for e in scene["entities"]}
    visuals = urdf_visuals()
    assert stamp == 0 and {k for k in entities if k.startswith("robot/")} == {f"robot/{k}" for k in visuals}
    for link, v in visuals.items():
        e = entities[f"robot/{link}"]
        assert e["frame_id"] == e["id"] and e["frame_locked"] is True
        assert e["timestamp"] == e["lifetime"] == {"sec": 0, "nsec": 0}  # from the start, for ever
        assert set(e) == {"timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "arrows", "lines",
                          "triangles", "texts", "cubes", "spheres", "cylinders", "models"}  # Foxglove's fields
        prims = {k: e[k] for k in ("cubes", "spheres", "cylinders", "models") if e[k]}
        kind = {"box": "cubes", "sphere": "spheres", "cylinder": "cylinders"}[v["kind"]]
        assert list(prims) == [kind] and len(prims[kind]) == 1
        [shape] = prims[kind]
        size = [shape["size"][k] for k in "xyz"]
        assert set(shape["size"]) == set("xyz")
        if kind == "cylinders":  # a cylinder, not a cone
            assert (shape["bottom_scale"], shape["top_scale"]) == (1.0, 1.0)
        want = v["size"] if kind == "cubes" else [2 * v["radius"][0]] * 3 if kind == "spheres" else \
            [2 * v["radius"][0], 2 * v["radius"][0], v["length"][0]]
        assert size == pytest.approx(want, abs=1e-6), link
        assert [shape["color"][k] for k in "rgba"] == pytest.approx(v["rgba"], abs=1e-6), link
        pos, orn = shape["pose"]["position"], shape["pose"]["orientation"]
        assert [pos[k] for k in "xyz"] == pytest.approx(v["xyz"], abs=1e-6), link  # in the link's own frame
        assert abs(orn["w"]) == pytest.approx(1.0, abs=1e-6), link
    [plane] = [e for k, e in entities.items() if k.startswith("plane/")]  # plane.urdf: plane100.obj, scale 1
    [model] = plane["models"]
    assert set(model) == {"pose", "scale", "color", "override_color", "url", "media_type", "data"}
    assert (model["media_type"], model["url"], model["override_color"]) == ("model/stl", "", True)
    assert [model["scale"][k] for k in "xyz"] == [1.0, 1.0, 1.0]
    obj = (Path(pybullet_data.getDataPath()) / "plane100.obj").read_text().splitlines()
    vertices = {tuple(np.float32(float(v)) for v in x.split()[1:4]) for x in obj if x.startswith("v ")}
    faces = [x.split()[1:] for x in obj if x.startswith("f ")]
    stl = base64.b64decode(model["data"])  # binary STL: 80-byte header, count, 50 bytes a triangle
    count = int(np.frombuffer(stl[80:84], "<u4")[0])
    assert count == sum(len(f) - 2 for f in faces) and len(stl) == 84 + 50 * count
    corners = np.frombuffer(stl[84:], np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))["v"]
    assert {tuple(c) for c in corners.reshape(-1, 3)} <= vertices  # every corner one of the OBJ's vertices
    wall = entities["wall/" + next(k.split("/")[1] for k in entities if k.startswith("wall/"))]
    [cube] = wall["cubes"]
    assert [cube["size"][k] for k in "xyz"] == pytest.approx([0.3, 2.0, 0.6])
    assert [cube["color"][k] for k in "rgba"] == pytest.approx([0.2, 0.7, 0.3, 1])


def test_the_record_samples_every_eighth_tick_and_ends_with_the_results_end(exported: Any) -> None:
    """docs/records.md: ``t = tick x time_step``, samples at pose_hz rounded to whole ticks from tick 0, a last
    sample of the final state; every trace record's ``t`` its tick's; the ``end`` record the result's."""
    record, _ = exported
    poses = np.load(record / "poses.npz")
    lines = (record / "trace.jsonl").read_text().splitlines()
    header, events = json.loads(lines[0]), [json.loads(x) for x in lines[1:]]
    result = json.loads((record / "result.json").read_text())
    step = header["time_step"]
    assert step == pytest.approx(1 / 240) and header["pose_hz"] == pytest.approx(30.0)
    ticks = [int(k) for k in poses["tick"]]
    assert ticks == [*range(0, result["ticks"], 8), result["ticks"]] or ticks == list(range(0, result["ticks"] + 1, 8))
    assert list(poses["t"]) == [k * step for k in ticks]
    assert [e["tick"] for e in events] == sorted(e["tick"] for e in events)
    assert all(e["t"] == pytest.approx(e["tick"] * step, abs=1e-12) for e in events)
    assert events[-1] == {"kind": "end", "tick": result["ticks"], "t": result["sim_time"],
                          "outcome": result["outcome"], "reason": result["reason"]}
    assert result["sim_time"] == pytest.approx(result["ticks"] * step)
    assert header["bodies"]["robot"]["joints"] == ["left_wheel", "right_wheel", "caster_wheel"] or \
        poses["joints/robot"].shape[1] == len(header["bodies"]["robot"]["joints"])


# ------------------------------------------------------------------------------------------ the same run as .rrd
@pytest.fixture(scope="module")
def rrd(exported: Any, tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[dict[str, Any]]]:
    """The ``.rrd`` export of the same record, read back with Rerun's own reader: entity -> rows of components
    (``sim`` in nanoseconds; absent on a static row)."""
    import pyarrow as pa
    import rerun.chunk

    record, _ = exported
    out = tmp_path_factory.mktemp("rrd") / "run.rrd"
    assert main(["export", str(record), "--rerun", str(out)]) == 0
    rows: dict[str, list[dict[str, Any]]] = {}
    for chunk in rerun.chunk.RrdReader(out).store().stream():
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if n != "rerun.controls.RowId"]
        cols = {n: (batch.column(n).cast(pa.int64()) if n == "sim" else batch.column(n)).to_pylist() for n in names}
        for i in range(batch.num_rows):
            rows.setdefault(chunk.entity_path, []).append({n: cols[n][i] for n in names if cols[n][i] is not None})
    return rows


@pytest.mark.slow  # Rerun's encoder and reader: ~2 s
def test_every_rerun_transform_is_the_mcap_transform_of_its_sample(exported: Any, rrd: Any) -> None:
    """The two exports carry the same poses at the same sim times (the MCAP's are checked against the URDF above):
    each ``world/<body>/<link>`` Transform3D at ``sim`` = the sample's time, nothing on a wall-clock timeline."""
    _, messages = exported
    for stamp, msg in messages["/tf"]:
        for x in msg["transforms"]:
            [row] = [r for r in rrd[f"/world/{x['child_frame_id']}"] if r.get("sim") == stamp
                     and "Transform3D:translation" in r]
            assert set(row) <= {"sim", *(k for k in row if k.startswith("Transform3D:"))}
            assert row["Transform3D:translation"][0] == pytest.approx([x["translation"][k] for k in "xyz"], abs=1e-5)
            q, want = row["Transform3D:quaternion"][0], [x["rotation"][k] for k in "xyzw"]
            assert abs(float(np.dot(q, want))) == pytest.approx(1.0, abs=1e-6), (stamp, x["child_frame_id"])


@pytest.mark.slow  # Rerun's encoder and reader: ~2 s
def test_every_rerun_log_line_is_the_mcap_log_line(exported: Any, rrd: Any) -> None:
    _, messages = exported
    got = sorted((r["sim"], path.removeprefix("/states/"), r["TextLog:text"][0], r["TextLog:level"][0])
                 for path, rows in rrd.items() if path.startswith("/states/") for r in rows if "TextLog:text" in r)
    want = sorted((stamp, m["name"], m["message"], "INFO") for stamp, m in messages["/states"])
    assert got == want and len(want) >= 2


@pytest.mark.slow  # Rerun's encoder and reader: ~2 s
def test_every_rerun_scan_point_is_a_return_of_the_mcap_scan(exported: Any, rrd: Any) -> None:
    """Each scan's points: the returns alone, in ray order, at origin + range along the ray in the scan's frame."""
    _, messages = exported
    points = {r["sim"]: r["Points3D:positions"] for r in rrd["/world/lidar/scan"] if "Points3D:positions" in r}
    assert len(points) == len(messages["/lidar/scan"])
    for stamp, scan in messages["/lidar/scan"]:
        p, o = scan["pose"]["position"], scan["pose"]["orientation"]
        origin, r = np.array([p[k] for k in "xyz"]), rotation([o[k] for k in "xyzw"])
        want = [origin + d * r @ np.array([math.cos(a), math.sin(a), 0.0]) for a, d in zip(
            np.linspace(scan["start_angle"], scan["end_angle"], len(scan["ranges"])), scan["ranges"], strict=True)
            if d > 0]
        assert np.allclose(np.array(points[stamp]).reshape(-1, 3), np.array(want).reshape(-1, 3), atol=1e-4), stamp


def unpacked(colour: int) -> list[float]:
    """A colour as Rerun stores it (0xRRGGBBAA) in 0..1."""
    return [(colour >> shift & 0xFF) / 255 for shift in (24, 16, 8, 0)]


@pytest.mark.slow  # Rerun's encoder and reader: ~2 s
def test_every_rerun_shape_is_its_links_urdf_visual(rrd: Any) -> None:
    for link, v in urdf_visuals().items():
        [row] = rrd[f"/world/robot/{link}/shape_0"]
        kind = {"box": "Boxes3D", "sphere": "Ellipsoids3D", "cylinder": "Cylinders3D"}[v["kind"]]
        assert {k.split(":")[0] for k in row} == {kind}, link
        assert row[f"{kind}:centers"][0] == pytest.approx(v["xyz"], abs=1e-6), link
        [colour] = row[f"{kind}:colors"]
        assert unpacked(colour) == pytest.approx(v["rgba"], abs=1 / 255), link  # the colour's float32, in bytes
        if kind == "Cylinders3D":
            assert (row["Cylinders3D:lengths"], row["Cylinders3D:radii"]) == (pytest.approx(v["length"]),
                                                                              pytest.approx(v["radius"])), link
        else:
            half = [s / 2 for s in v["size"]] if kind == "Boxes3D" else v["radius"] * 3
            assert row[f"{kind}:half_sizes"][0] == pytest.approx(half, abs=1e-6), link
    [wall] = [rows[0] for path, rows in rrd.items() if path.startswith("/world/wall/") and path.endswith("/shape_0")]
    assert wall["Boxes3D:half_sizes"][0] == pytest.approx([0.15, 1.0, 0.3], abs=1e-6)
    assert unpacked(wall["Boxes3D:colors"][0]) == pytest.approx([0.2, 0.7, 0.3, 1], abs=1 / 255)


def test_the_pages_replay_is_every_sample_of_the_checked_transforms(exported: Any) -> None:
    """``robokit view``'s replay data: sample times, and per sample every link's pose as the (checked) MCAP
    transforms give it, NaN for the removed post; each machine's stays; a thinned replay (every n-th sample and the
    last) is the same rows."""
    import base64

    from robokit.record.format import RunRecord
    from robokit.record.replay import payload, replay_of

    record, messages = exported
    rec = RunRecord(record)
    full = replay_of(rec)
    data = payload(rec, full)
    t = np.frombuffer(base64.b64decode(data["t"]), np.float32)
    poses = np.frombuffer(base64.b64decode(data["poses"]), np.float32).reshape(len(t), len(data["links"]), 7)
    assert np.array_equal(t, np.load(record / "poses.npz")["t"].astype(np.float32))
    tf = messages["/tf"]
    assert len(tf) == len(t)
    for (stamp, msg), row in zip(tf, poses, strict=True):
        got = {x["child_frame_id"]: x for x in msg["transforms"]}
        for path, pose in zip(data["links"], row, strict=True):
            if path not in got:
                assert path.startswith("post/") and np.isnan(pose).all(), (stamp, path)
                continue
            x = got[path]
            assert pose[:3] == pytest.approx([x["translation"][k] for k in "xyz"], abs=1e-5)
            assert abs(float(np.dot(pose[3:], [x["rotation"][k] for k in "xyzw"]))) == pytest.approx(1.0, abs=1e-5)
    result = json.loads((record / "result.json").read_text())
    assert data["duration"] == pytest.approx(max(result["sim_time"], float(t[-1])))
    assert data["machines"] == [{"name": name, "spans": [[s.state, s.start, s.end] for s in stays]}
                                for name, stays in rec.spans().items()]
    thin = replay_of(rec, every=5)
    picked = sorted({*range(0, len(t), 5), len(t) - 1})
    assert np.array_equal(thin.t, full.t[picked])
    assert np.array_equal(thin.poses, full.poses[picked], equal_nan=True)


# ------------------------------------------------------------------------------------------ generated long records
@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(0, 5e4, allow_nan=False), min_size=1, max_size=6, unique=True),
       st.lists(st.tuples(st.floats(0, 5e4, allow_nan=False), st.sampled_from(["arm", "base"]),
                          st.sampled_from(["IDLE", "MOVE"])), max_size=4),
       st.integers(0, 2**16), st.booleans())
def test_every_message_of_a_long_record_keeps_its_time_and_pose(
        tmp_path_factory: pytest.TempPathFactory, times: list[float], moves: list[tuple[float, str, str]],
        seed: int, named: bool) -> None:
    """Sample and transition times past one second (up to half a day): each message's log time is the sim time in
    nanoseconds and its timestamp ``sec`` / ``nsec`` that split; each transform the pose given, a link whose body is
    removed (NaN) left out; a header without machines logs its transitions alone."""
    from mcap.reader import make_reader

    from robokit.record.export import export_mcap
    from robokit.record.format import RunRecord
    from robokit.record.replay import Link, Replay

    rng = np.random.default_rng(seed)
    t = np.array(sorted(times))
    poses = rng.normal(size=(len(t), 2, 7))
    poses[:, :, 3:] /= np.linalg.norm(poses[:, :, 3:], axis=2, keepdims=True)
    poses[rng.random(len(t)) < 0.3, 1] = np.nan  # the second link's body removed at some samples
    folder = tmp_path_factory.mktemp("run")
    header = {"kind": "header", "schema": "robokit.record/1", "config": {}, "time_step": 1 / 240}
    if named:
        header["machines"] = [{"name": "arm", "initial": "IDLE"}, {"name": "base", "initial": "MOVE"}]
    events = [{"kind": "transition", "t": at, "tick": round(at * 240), "machine": m, "source_state": "X",
               "dest_state": d, "trigger": "go"} for at, m, d in sorted(moves)]
    (folder / "trace.jsonl").write_text("\n".join(json.dumps(x) for x in [header, *events]) + "\n")
    replay = Replay([Link("a", "base", -1), Link("b", "tip", 3)], [], t, poses)
    out = folder / "long.mcap"
    export_mcap(RunRecord(folder), out, replay)
    with out.open("rb") as f:
        messages = [(c.topic, m.log_time, m.publish_time, json.loads(m.data)) for _, c, m in
                    make_reader(f).iter_messages()]

    def stamp(seconds: float) -> dict[str, int]:
        ns = round(seconds * 1e9)
        return {"sec": ns // 10**9, "nsec": ns % 10**9}

    tf = [(log, msg) for topic, log, pub, msg in messages if topic == "/tf" and log == pub]
    assert [log for log, _ in tf] == [round(x * 1e9) for x in t]
    for (_, msg), row, at in zip(tf, poses, t, strict=True):
        want = [(path, p) for path, p in zip(["a/base", "b/tip"], row, strict=True) if not np.isnan(p[0])]
        assert [x["child_frame_id"] for x in msg["transforms"]] == [path for path, _ in want]
        for x, (_, p) in zip(msg["transforms"], want, strict=True):
            assert x["timestamp"] == stamp(at) and x["parent_frame_id"] == "world"
            assert [x["translation"][k] for k in "xyz"] + [x["rotation"][k] for k in "xyzw"] == list(p)
    logs = [(log, msg) for topic, log, _, msg in messages if topic == "/states"]
    want_logs = [(0.0, m, f"{m}: start in {s}") for m, s in ([("arm", "IDLE"), ("base", "MOVE")] if named else [])]
    want_logs += [(at, m, f"{m}: X -> {d} (go)") for at, m, d in sorted(moves)]
    assert [(log, msg["timestamp"], msg["name"], msg["message"]) for log, msg in logs] == [
        (round(at * 1e9), stamp(at), m, text) for at, m, text in want_logs]
