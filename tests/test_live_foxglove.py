"""The live view over the Foxglove WebSocket protocol (foxglove-sdk's server), read by a plain WebSocket client
speaking the protocol: the channels of the .mcap export are advertised, ``/tf`` carries the cube's pose as the world
has it, ``/scene`` the cube's box as PyBullet holds it; a lidar's ``/lidar/NAME`` scan ends on the wall the world
has and a camera's ``/camera/NAME`` image is the camera's."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import pytest
from live_run import LiveRun

pytestmark = pytest.mark.slow  # a few seconds: the default tier's budget is kept for the checks without a client

pytest.importorskip("foxglove")
websockets_sync = pytest.importorskip("websockets.sync.client")

SORT = str(Path(__file__).resolve().parent.parent / "configs" / "sort_robot.toml")


def _next(ws: Any, wanted: dict[int, str], topic: str) -> dict[str, Any]:
    """The next message on ``topic`` (binary message data, opcode 1: subscription id, log time, JSON payload)."""
    while True:
        data = ws.recv(timeout=60)
        if isinstance(data, bytes) and data[0] == 1:
            sub, _log_time = struct.unpack_from("<IQ", data, 1)
            if wanted[sub] == topic:
                return dict(json.loads(data[13:]))


def test_foxglove_clients_get_the_exports_topics_live() -> None:
    from websockets.sync.client import connect

    live = LiveRun(SORT, 20.0, foxglove=True)
    try:
        live.run_to(1500)  # past the first pick's transitions
        bridge = live.view.foxglove
        with connect(f"ws://127.0.0.1:{bridge.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                     open_timeout=60, max_size=None) as ws:  # the scene embeds its meshes
            channels: dict[str, dict[str, Any]] = {}
            while len(channels) < 4:
                msg = ws.recv(timeout=60)
                if isinstance(msg, str) and json.loads(msg).get("op") == "advertise":
                    channels.update({c["topic"]: c for c in json.loads(msg)["channels"]})
            assert {t: c["schemaName"] for t, c in channels.items()} == {
                "/tf": "foxglove.FrameTransforms", "/scene": "foxglove.SceneUpdate", "/states": "foxglove.Log",
                "/camera/camera": "foxglove.CompressedImage"}
            subs = {i: topic for i, topic in enumerate(("/tf", "/scene"), 1)}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[topic]["id"]} for i, topic in subs.items()]}))
            scene = _next(ws, subs, "/scene")  # sent on subscribing: both subscriptions hold from then on
            tick = live.step()  # one more frame, for /tf
            ns = round(round(tick / 240, 6) * 1e9)  # frames carry sim time to the microsecond
            tf_msg = _next(ws, subs, "/tf")
            while tf_msg["transforms"][0]["timestamp"] != {"sec": ns // 10**9, "nsec": ns % 10**9}:
                tf_msg = _next(ws, subs, "/tf")  # a frame logged before the step
        world, client = live.sim.world, live.sim.world.client
        pos, orn = client.getBasePositionAndOrientation(world.body("red_0"))
        tf = next(t for t in tf_msg["transforms"] if t["child_frame_id"].startswith("red_0/"))
        assert [tf["translation"][k] for k in "xyz"] == pytest.approx(list(pos), abs=2e-6)
        assert [tf["rotation"][k] for k in "xyzw"] == pytest.approx(list(orn), abs=2e-6)
        cube = next(e for e in scene["entities"] if e["id"].startswith("red_0/"))
        size = client.getVisualShapeData(world.body("red_0"))[0][3]
        assert [cube["cubes"][0]["size"][k] for k in "xyz"] == pytest.approx(list(size))
    finally:
        live.close()


def _until(test: Any) -> None:
    """Wait (polling, at most a minute) until ``test()`` holds."""
    import time

    end = time.monotonic() + 60
    while not test():
        assert time.monotonic() < end, "it never held"
        time.sleep(0.01)


def test_foxglove_clients_get_the_lidar_and_the_camera_of_the_world(tmp_path: Path) -> None:
    import base64
    import math

    import cv2
    import numpy as np
    from live_run import WALL_FACE, sensors_config
    from websockets.sync.client import connect

    live = LiveRun(sensors_config(tmp_path), 1.0, foxglove=True)
    try:
        live.held_at(0)  # the run has started: its sensors' topics exist
        bridge = live.view.foxglove
        with connect(f"ws://127.0.0.1:{bridge.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                     open_timeout=60, max_size=None) as ws:
            channels: dict[str, dict[str, Any]] = {}
            while not {"/lidar/lidar", "/camera/cam"} <= set(channels):
                msg = ws.recv(timeout=60)
                if isinstance(msg, str) and json.loads(msg).get("op") == "advertise":
                    channels.update({c["topic"]: c for c in json.loads(msg)["channels"]})
            assert channels["/lidar/lidar"]["schemaName"] == "foxglove.LaserScan"
            assert channels["/camera/cam"]["schemaName"] == "foxglove.CompressedImage"
            subs = {1: "/lidar/lidar", 2: "/camera/cam"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[topic]["id"]} for i, topic in subs.items()]}))
            _until(lambda: live.view.feed.wanted == {"lidar", "cam"})  # the subscriptions reached the bridge
            live.post("/control", {"action": "step", "value": "80"})
            live.held_at(80)
            stamp = {"sec": 0, "nsec": round(79 / 240 * 1e9)}
            got: dict[str, dict[str, Any]] = {}
            while len(got) < 2:  # each topic's message of tick 79 (the last that ran), in whatever order they come
                data = ws.recv(timeout=60)
                if isinstance(data, bytes) and data[0] == 1:
                    message = json.loads(data[13:])
                    if message["timestamp"] == stamp:
                        got[subs[struct.unpack_from("<I", data, 1)[0]]] = message
            scan, image = got["/lidar/lidar"], got["/camera/cam"]
        ranges = np.asarray(scan["ranges"])
        angles = np.linspace(scan["start_angle"], scan["end_angle"], len(ranges))
        o, q = scan["pose"]["position"], scan["pose"]["orientation"]
        yaw = 2 * math.atan2(q["z"], q["w"])
        hit = ranges > 0
        x = o["x"] + ranges[hit] * np.cos(angles[hit] + yaw)  # where each returning ray ends
        assert hit.sum() >= 5 and x == pytest.approx(WALL_FACE, abs=3e-3)  # on the wall's face
        assert image["format"] == "jpeg"
        shown = cv2.imdecode(np.frombuffer(base64.b64decode(image["data"]), np.uint8), cv2.IMREAD_COLOR)
        own = live.sim.scheduler.slots["cam"].value.rgb  # the camera's image at tick 79
        assert np.abs(cv2.cvtColor(shown, cv2.COLOR_BGR2RGB).astype(int) - own.astype(int)).mean() < 1.5
    finally:
        live.close()
