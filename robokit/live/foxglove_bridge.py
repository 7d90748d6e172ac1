"""The live view in the Foxglove app: the Foxglove WebSocket protocol through Foxglove's own SDK (``foxglove-sdk``,
the ``foxglove`` extra), with the topics and JSON schemas of ``robokit export --mcap``
(:mod:`robokit.record.export`): ``/tf`` (``foxglove.FrameTransforms``, every drawn link's world pose),
``/scene`` (``foxglove.SceneUpdate``, each link's shapes, frame-locked; sent when a client subscribes) and
``/states`` (``foxglove.Log``, each state machine's transitions), and per sensor ``/lidar/NAME``
(``foxglove.LaserScan``) and ``/camera/NAME`` (``foxglove.CompressedImage``, JPEG), each carried while a client is
subscribed to it (the live view's sensor feed is asked for it as a page asks: :mod:`robokit.live.sensors`).

It is a reader of the live view's one-slot buffer like a page: its own thread takes the latest frame when it is
ready for one, so the loop never waits for it either. Log times are sim time (nanoseconds).
"""

from __future__ import annotations

import base64
import json
import threading
from typing import Any

import numpy as np

from robokit.errors import UserError

TOPICS = {"/tf": "foxglove.FrameTransforms", "/scene": "foxglove.SceneUpdate", "/states": "foxglove.Log"}


def _ns(t: float) -> int:
    return int(round(t * 1e9))


def _stamp(t: float) -> dict[str, int]:
    ns = _ns(t)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


class FoxgloveBridge:
    """Serves a :class:`robokit.live.view.LiveView`'s frames to Foxglove clients on ``host:port``.

    Raises:
        UserError: ``foxglove-sdk`` is not installed, or ``host:port`` cannot be served.
    """

    def __init__(self, view: Any, host: str, port: int) -> None:
        try:
            import foxglove
        except ImportError:
            raise UserError("--live-foxglove needs foxglove-sdk, which is not installed: "
                            "pip install 'robokit[foxglove]'") from None

        from robokit.record.export import SCHEMAS

        self.view = view
        self.context = foxglove.Context()

        def channel(topic: str, schema: str) -> Any:
            return foxglove.Channel(topic, message_encoding="json", context=self.context, schema=foxglove.Schema(
                name=schema, encoding="jsonschema",
                data=json.dumps({"title": schema, "type": "object", "properties": SCHEMAS[schema]}).encode()))

        self._channel = channel
        self.channels = {topic: channel(topic, schema) for topic, schema in TOPICS.items()}
        self.sensor_topics: dict[str, str] = {}
        """Sensor topic -> the sensor's name (set when the run starts: :meth:`add_sensors`)."""
        self._subscribed: dict[str, int] = {}  # sensor name -> subscriptions to its topic
        self._sent: dict[str, int] = {}  # sensor name -> the tick of the reading last logged
        self._scene: dict[str, Any] | None = None
        self._lock = threading.Lock()
        bridge = self

        class Listener(foxglove.ServerListener):  # type: ignore[misc]
            def on_subscribe(self, client: Any, channel: Any) -> None:
                if channel.topic == "/scene":
                    bridge.send_scene()
                bridge.watch(channel.topic, 1)

            def on_unsubscribe(self, client: Any, channel: Any) -> None:
                bridge.watch(channel.topic, -1)

        try:
            self.server = foxglove.start_server(name="robokit", host=host, port=port, context=self.context,
                                                server_listener=Listener())
        except RuntimeError as exc:  # the SDK's FoxgloveError: a port taken, an address that cannot be bound
            raise UserError(f"--live-foxglove: cannot serve on {host}:{port}: {exc}") from None
        self.port = int(self.server.port)
        self.url = f"ws://{host}:{self.port}"
        self._seen_transitions: set[tuple[Any, ...]] = set()
        self._thread = threading.Thread(target=self._forward, name="robokit-foxglove", daemon=True)
        self._thread.start()

    def add_sensors(self, feed: Any) -> None:
        """A topic for each lidar and camera of the run (:class:`robokit.live.sensors.SensorFeed`)."""
        for name, kind in feed.kinds.items():
            if kind in ("scan", "image"):
                topic = f"/lidar/{name}" if kind == "scan" else f"/camera/{name}"
                self.channels[topic] = self._channel(
                    topic, "foxglove.LaserScan" if kind == "scan" else "foxglove.CompressedImage")
                self.sensor_topics[topic] = name

    def watch(self, topic: str, change: int) -> None:
        """A client subscribed to (``change`` 1) or left (-1) ``topic``: ask the feed for the sensors watched."""
        name = self.sensor_topics.get(topic)
        feed = self.view.feed
        if name is None or feed is None:
            return
        with self._lock:
            self._subscribed[name] = max(0, self._subscribed.get(name, 0) + change)
            feed.ask(id(self), [n for n, count in self._subscribed.items() if count > 0])

    def scene(self) -> dict[str, Any]:
        """``/scene``'s message: each drawn link's shapes as a frame-locked entity (meshes embedded), built once."""
        from robokit.record.export import _entity
        from robokit.record.replay import Replay, Shape

        with self._lock:
            if self._scene is None:
                links = self.view.links
                shapes = [Shape(s["frame"], s["kind"], tuple(s["size"]), s.get("mesh_file", ""), tuple(s["rgba"]),
                                tuple(s["position"]), tuple(s["quaternion"]))
                          for s in self.view.server.scene["shapes"]]
                replay = Replay(links, shapes, np.zeros(1), np.zeros((1, len(links), 7)))
                self._scene = {"deletions": [], "entities": [_entity(replay, k) for k in range(len(links))]}
            return self._scene

    def send_scene(self) -> None:
        if self.view.server.scene is not None:
            self.channels["/scene"].log(self.scene(), log_time=_ns(self.view.sim.world.time))

    def _forward(self) -> None:
        seen, publisher = 0, self.view.publisher
        while not publisher.closed:
            frame = publisher.take(seen, 1.0)
            if frame is None:
                continue
            seen = frame["seq"]
            self.log_frame(frame)

    def log_frame(self, frame: dict[str, Any]) -> None:
        """A frame's link poses on ``/tf`` and the transitions not sent yet on ``/states``."""
        t, poses, paths = frame["t"], frame["poses"], self.view.server.scene["links"]
        tfs = [{"timestamp": _stamp(t), "parent_frame_id": "world", "child_frame_id": path,
                "translation": dict(zip("xyz", poses[7 * k:7 * k + 3], strict=True)),
                "rotation": dict(zip("xyzw", poses[7 * k + 3:7 * k + 7], strict=True))}
               for k, path in enumerate(paths) if poses[7 * k] is not None]
        self.channels["/tf"].log({"transforms": tfs}, log_time=_ns(t))
        for name, reading in (frame.get("sensors") or {}).items():
            self.log_sensor(name, reading)
        for r in frame["recent"]:
            if r.get("kind") != "transition":
                continue
            key = (r["tick"], r.get("machine"), r.get("source_state"), r.get("dest_state"))
            if key in self._seen_transitions:
                continue
            self._seen_transitions.add(key)
            message = f"{r['source_state']} -> {r['dest_state']} ({r.get('trigger', '')})"
            self.channels["/states"].log({"timestamp": _stamp(r["t"]), "level": 2, "message": message,
                                          "name": r.get("machine", ""), "file": "", "line": 0},
                                         log_time=_ns(r["t"]))

    def log_sensor(self, name: str, reading: dict[str, Any]) -> None:
        """A lidar's scan on ``/lidar/NAME`` or a camera's image on ``/camera/NAME``, once per reading."""
        from robokit.record.export import _pose

        kind, tick = reading["kind"], reading["tick"]
        topic = f"/lidar/{name}" if kind == "scan" else f"/camera/{name}"
        if topic not in self.sensor_topics or tick < 0 or self._sent.get(name) == tick:
            return
        self._sent[name] = tick
        t = tick * self.view.sim.world.time_step
        if kind == "scan":
            yaw = reading["yaw"]
            count = len(reading["ranges"])
            self.channels[topic].log({
                "timestamp": _stamp(t), "frame_id": "world",
                "pose": _pose(reading["origin"], (0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2))),
                "start_angle": reading["angle_min"],
                "end_angle": reading["angle_min"] + reading["angle_increment"] * (count - 1),
                "ranges": reading["ranges"], "intensities": []}, log_time=_ns(t))
            return
        image = self.view.feed.jpeg(name)
        if image is None or image[0] != tick:
            return
        self.channels[topic].log({"timestamp": _stamp(t), "frame_id": name, "format": "jpeg",
                                  "data": base64.b64encode(image[1]).decode("ascii")}, log_time=_ns(t))

    def stop(self) -> None:
        self.server.stop()
        self._thread.join(2)
