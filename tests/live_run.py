"""Helpers of the live view's tests: a run in a thread with its live view, driven over HTTP as the page drives it."""

from __future__ import annotations

import json
import math
import threading
import urllib.request
from typing import Any

from robokit.config import load_config
from robokit.core.result import RunResult
from robokit.core.simulation import Simulation
from robokit.live import LiveView
from robokit.plugin_api.plugins import load_plugins

WAIT = 60.0
"""Wall seconds a frame may take to come (a safety net on a loaded machine; the tests never sleep)."""


def plain_run(config: str, max_time: float, overrides: dict[str, Any] | None = None) -> tuple[RunResult, list[Any]]:
    """The same config run without a live view: the result and the trace."""
    plugins = load_plugins()
    with Simulation(load_config(config, plugins, overrides), plugins) as sim:
        return sim.run(max_time=max_time), list(sim.trace)


def final_pose(config: str, max_time: float, overrides: dict[str, object]) -> tuple[tuple[float, ...], ...]:
    """The robot's base pose at the end of a run of ``config`` without a live view."""
    plugins = load_plugins()
    with Simulation(load_config(config, plugins, overrides), plugins) as sim:
        sim.run(max_time=max_time)
        pos, orn = sim.world.client.getBasePositionAndOrientation(sim.world.body("robot"))
        return tuple(pos), tuple(orn)


class LiveRun:
    """A run with a live view (started paused, as fast as possible when let go) in a thread."""

    def __init__(self, config: str, max_time: float, overrides: dict[str, Any] | None = None, *,
                 foxglove: bool = False, sensors: tuple[str, ...] = ()) -> None:
        plugins = load_plugins()
        self.max_time = max_time
        self.view = LiveView("127.0.0.1", 0, paused=True, speed=math.inf, announce=False,
                             foxglove_port=0 if foxglove else None, sensors=sensors)
        plugins.pm.register(self.view, name="robokit-live")
        self.sim = Simulation(load_config(config, plugins, overrides), plugins)
        self.result: RunResult | None = None
        self.seen = 0
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        self.result = self.sim.run(max_time=self.max_time)

    def post(self, path: str, body: dict[str, Any]) -> dict[str, Any]:
        req = urllib.request.Request(self.view.url + path.lstrip("/"), data=json.dumps(body).encode(),
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=WAIT) as reply:
            return dict(json.loads(reply.read()))

    def get(self, path: str) -> tuple[bytes, dict[str, str]]:
        """A GET of ``path``: the body and the headers."""
        with urllib.request.urlopen(self.view.url + path.lstrip("/"), timeout=WAIT) as reply:
            return reply.read(), dict(reply.headers)

    def state(self) -> dict[str, Any]:
        with urllib.request.urlopen(self.view.url + "state", timeout=WAIT) as reply:
            return dict(json.loads(reply.read()))

    def frame_where(self, test: Any) -> dict[str, Any]:
        """The first newly published frame for which ``test(frame)`` holds."""
        while True:
            frame = self.view.publisher.take(self.seen, WAIT)
            assert frame is not None, "no frame came"
            self.seen = frame["seq"]
            if test(frame):
                return frame

    def held_at(self, tick: int) -> dict[str, Any]:
        """Wait until the run is held at ``tick``."""
        return self.frame_where(lambda f: f["paused"] and f["tick"] == tick)

    def step(self) -> int:
        """One tick from the held one; the tick the run is held at next."""
        tick = self.sim.world.tick
        self.post("/control", {"action": "step"})
        self.held_at(tick + 1)
        return tick + 1

    def run_to(self, tick: int) -> dict[str, Any]:
        """From the start (held at tick 0), let the run go ``tick`` ticks in one ``step`` and wait until it is held
        there: a point in the run that does not depend on how fast the machine answers."""
        self.post("/control", {"action": "step", "value": str(tick)})
        return self.held_at(tick)

    def finish(self) -> tuple[RunResult, list[Any]]:
        self.post("/control", {"action": "speed", "value": "max"})
        self.post("/control", {"action": "resume"})
        self.thread.join(WAIT)
        assert self.result is not None
        return self.result, list(self.sim.trace)

    def close(self) -> None:
        if self.thread.is_alive():
            self.sim.interrupt("test")
            self.thread.join(WAIT)
        self.view.close(grace=0)
        self.sim.close()



SENSORS_WORLD = """
[world]
seed = 1
max_time = 5.0

[bodies.floor]
shape = "box"
size = [4.0, 4.0, 0.1]
mass = 0
position = [0, 0, -0.05]
rgba = [0.75, 0.75, 0.7, 1]

[bodies.wall]
shape = "box"
size = [0.1, 2.0, 0.5]
mass = 0
position = [1.0, 0.0, 0.25]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
mass = 1.0
position = [0.0, -0.6, 0.3]
rgba = [0.9, 0.2, 0.2, 1]

[robots.robot]
urdf = "robots/diffbot.urdf"
position = [0, 0, 0.06]

[sensors.lidar]
type = "lidar"
robot = "robot"
link = "lidar_link"
rays = 36
range_max = 3.0

[sensors.touch]
type = "contact"
body = "box"

[sensors.cam]
type = "camera"
width = 64
height = 48
eye = [0.0, -1.0, 0.35]
target = [0.0, -0.6, 0.15]
renderer = "tiny"

[behaviour]
type = "record"
duration = 0
"""
"""A diffbot with a 36-ray lidar facing a wall whose face is the plane x = 0.95 (|y| <= 1, 0 <= z <= 0.5), a box
dropped from 0.3 m onto the floor with a contact sensor, a small camera looking at the box; the ``record`` behaviour
reads every sensor every tick and writes each reading into the trace."""
WALL_FACE = 0.95


def sensors_config(folder: Any, camera: bool = True, contact: bool = True) -> str:
    """:data:`SENSORS_WORLD` written to ``folder`` (without its camera, or its contact sensor, if asked); its path."""
    text = SENSORS_WORLD
    for section, keep in (("[sensors.cam]", camera), ("[sensors.touch]", contact)):
        if not keep:
            start = text.index(section)
            text = text[:start] + text[text.index("\n[", start + 1) + 1:]
    path = folder / f"sensors{'' if camera else '_no_camera'}{'' if contact else '_no_contact'}.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def pose_at(config: str, tick: int, overrides: dict[str, Any], body: str) -> tuple[float, ...]:
    """``body``'s base pose (link frame: position, quaternion) after ``tick`` ticks of a run without a live view."""
    plugins = load_plugins()
    with Simulation(load_config(config, plugins, overrides), plugins) as sim:
        sim.run(max_time=tick * sim.world.time_step)
        assert sim.world.tick == tick
        pos, orn = sim.world.pose(body)
        return (*pos, *orn)


def camera_at(config: str, tick: int) -> Any:
    """Camera ``cam``'s image (H x W x 3 uint8) at ``tick`` of a run of ``config`` without a live view: the run
    stopped after ``tick`` ticks, then the camera read in that world."""
    plugins = load_plugins()
    with Simulation(load_config(config, plugins), plugins) as sim:
        sim.run(max_time=tick * sim.world.time_step)
        assert sim.world.tick == tick
        return sim.components["cam"].read().rgb
