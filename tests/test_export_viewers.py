"""``robokit export``: a record as a Rerun recording and as MCAP with Foxglove schemas, each read back by that
tool's own Python reader (rerun's ``RrdReader``, mcap's ``make_reader``), with counts worked out from the URDF, the
pose log, the saved frames and the trace."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import find_run

ROOT = Path(__file__).resolve().parent.parent
DIFFBOT = ROOT / "robokit" / "data" / "robots" / "diffbot.urdf"

MOBILE = f"""
[world]
max_time = 0.5

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box_a]
shape = "box"
size = [1.0, 1.0, 1.0]
mass = 0
position = [2.0, 1.0, 0.5]
rgba = [0.8, 0.2, 0.2, 1]

[robots.robot]
urdf = "{DIFFBOT}"
position = [0, 0, 0.06]

[sensors.scan]
type = "lidar"
rate_hz = 10
link = "lidar_link"
rays = 360
range_max = 5.0

[actuators.drive]
type = "diff_drive"
left_wheels = ["left_wheel"]
right_wheels = ["right_wheel"]
wheel_radius = 0.05
track_width = 0.26

[behaviour]
type = "go_to_goal"
goal = [5.0, 3.0]
timeout = 80.0
"""


CAMERA = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[sensors.cam]
type = "camera"
width = 32
height = 24
eye = [1.5, 0, 0.8]
target = [0, 0, 0.2]

[behaviour]
type = "record"
components = ["cam"]
rate_hz = 4
duration = 1.0
"""


def run_in(folder: Path, config: str, *flags: str) -> Path:
    import os

    (folder / "scene.toml").write_text(config)
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        assert main(["run", "scene.toml", "--quiet", *flags]) in (0, 1)  # go_to_goal runs out of time: fine here
    finally:
        os.chdir(cwd)
    return find_run("last", folder / "results").folder


@pytest.fixture(scope="module")
def record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return run_in(tmp_path_factory.mktemp("export"), MOBILE)


def expected(folder: Path) -> dict[str, int]:
    """Counts from the sources: URDF links with a visual (+ the plane's, + one box), pose samples, frames, trace."""
    urdf_links = [link.get("name") for link in ET.parse(DIFFBOT).getroot().iter("link") if link.find("visual")
                  is not None]
    events = [json.loads(line) for line in (folder / "trace.jsonl").read_text().splitlines()[1:]]
    header = json.loads((folder / "trace.jsonl").read_text().splitlines()[0])
    return {"frames": len(urdf_links) + 2, "samples": len(np.load(folder / "poses.npz")["t"]),
            "logs": len(header["machines"]) + sum(e["kind"] == "transition" for e in events),
            "urdf_links": len(urdf_links)}


def test_rerun_recording_reads_back_with_every_entity(record: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    import rerun.chunk

    want = expected(record)
    assert want["logs"] >= 2 and want["urdf_links"] == 7
    out = tmp_path / "run.rrd"
    assert main(["export", str(record), "--rerun", str(out)]) == 0
    assert f"{out}: 9 shapes, {want['frames'] * want['samples']} transforms" in capsys.readouterr().out
    rows: Counter[str] = Counter()
    for chunk in rerun.chunk.RrdReader(out).store().stream():
        rows[chunk.entity_path] += chunk.num_rows
    frames = {p for p in rows if p.startswith("/world/") and "/shape_" not in p and "/lidar/" not in p}
    assert len(frames) == want["frames"]
    assert {p.split("/")[3] for p in frames if p.startswith("/world/robot/")} == {
        link.get("name") for link in ET.parse(DIFFBOT).getroot().iter("link") if link.find("visual") is not None}
    assert all(rows[p] == want["samples"] for p in frames)  # one transform per pose sample
    assert sum("/shape_" in p for p in rows) == want["frames"]  # one visual shape per link here
    assert rows["/world/lidar/scan"] == want["samples"]
    assert sum(n for p, n in rows.items() if p.startswith("/states/")) == want["logs"]


def test_mcap_reads_back_with_foxglove_channels(record: Path, tmp_path: Path) -> None:
    from mcap.reader import make_reader

    want = expected(record)
    out = tmp_path / "run.mcap"
    assert main(["export", str(record), "--mcap", str(out)]) == 0
    with out.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        schema = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
        messages: dict[str, dict] = {}
        for _, channel, message in reader.iter_messages():
            messages.setdefault(channel.topic, json.loads(message.data))
    assert schema == {"/scene": "foxglove.SceneUpdate", "/tf": "foxglove.FrameTransforms",
                      "/lidar/scan": "foxglove.LaserScan", "/states": "foxglove.Log"}
    assert counts == {"/scene": 1, "/tf": want["samples"], "/lidar/scan": want["samples"],
                      "/states": want["logs"]}
    assert len(messages["/scene"]["entities"]) == len(messages["/tf"]["transforms"]) == want["frames"]
    header = json.loads((record / "trace.jsonl").read_text().splitlines()[0])
    machine = header["machines"][0]
    assert messages["/states"]["message"] == f"{machine['name']}: start in {machine['initial']}"
    scan = messages["/lidar/scan"]
    ranges, origin = scan["ranges"], scan["pose"]["position"]
    # at t = 0 the robot faces +x: the ray towards the box's near face (x = 1.5, y = 0.75) meets it at x = 1.5
    angle = math.atan2(0.75 - origin["y"], 1.5 - origin["x"])
    k = round((angle - scan["start_angle"]) / (2 * math.pi / len(ranges)))
    a = scan["start_angle"] + k * 2 * math.pi / len(ranges)
    assert ranges[k] == pytest.approx((1.5 - origin["x"]) / math.cos(a), abs=0.02)
    assert ranges[180 + 90] == 0.0  # straight ahead-left (+y): nothing within 5 m, "no return"


def test_saved_camera_frames_become_images_in_both(tmp_path: Path) -> None:
    import cv2
    import rerun.chunk
    from mcap.reader import make_reader

    folder = run_in(tmp_path, CAMERA, "--save-frames")
    pngs = sorted((folder / "frames").glob("cam_*_rgb.png"))
    assert len(pngs) == 5  # read 4 times a second for 1 s, both ends
    assert main(["export", str(folder), "--rerun", str(tmp_path / "c.rrd"), "--mcap", str(tmp_path / "c.mcap")]) == 0
    rows = Counter[str]()
    for chunk in rerun.chunk.RrdReader(tmp_path / "c.rrd").store().stream():
        rows[chunk.entity_path] += chunk.num_rows
    assert rows["/camera/cam"] == len(pngs)
    with (tmp_path / "c.mcap").open("rb") as f:
        images = [(m.log_time, json.loads(m.data)) for _, c, m in make_reader(f).iter_messages(topics=["/camera/cam"])]
    assert [t for t, _ in images] == [round(int(p.name.split("_")[1]) / 240 * 1e9) for p in pngs]
    import base64

    first = cv2.imdecode(np.frombuffer(base64.b64decode(images[0][1]["data"]), np.uint8), cv2.IMREAD_COLOR)
    original = cv2.imread(str(pngs[0]))
    assert first is not None and original is not None
    assert images[0][1]["format"] == "png" and np.array_equal(first, original)
