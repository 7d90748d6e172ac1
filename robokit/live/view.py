"""The live view's side of the loop: a monitor that publishes the scene, the state machines and the clock, and paces
the run to real time (or holds it, steps it, speeds it up) as the page asks.

It attaches to a run through the lifecycle hooks (:meth:`LiveView.robokit_run_start`), as any plugin may: a monitor
slot in the loop (:meth:`robokit.core.simulation.Simulation.add_monitor`), a trace listener (the same records the run
record writes), and the page's keys handed to every component that takes them (the keyboard sensor's
``key_source``). Frames are taken at most ``fps`` times per wall second, and at every tick while paused.
"""

from __future__ import annotations

import base64
import math
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from robokit import hookimpl
from robokit.errors import UserError
from robokit.live.publisher import Control, PageKeys, Publisher

TRANSITIONS_KEPT = 12
"""How many of the latest transitions (and composite events) a frame carries."""


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
    links, items = visual_links(world)
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
    client = world.client
    out: list[float | None] = []
    for link in links:
        if not world.has_body(link.body):
            out += [None] * 7
            continue
        bid = world.body(link.body)
        if link.index < 0:
            pos, orn = _base_frame(client, bid)
        else:
            state = client.getLinkState(bid, link.index, computeForwardKinematics=True)
            pos, orn = state[4], state[5]
        out += [round(float(v), 6) for v in (*pos, *orn)]
    return out


class LiveView:
    """A running run's live page: register it as a plugin before the run (``plugins.pm.register(view)``); it starts
    its server at once, shows the run's world when the run starts, and keeps serving until :meth:`close`.

    Args:
        host: Address to bind (``127.0.0.1``; any other needs the token in the URL).
        port: TCP port (0: any free one).
        paused: Start held at tick 0 (the page's resume or step lets it go).
        speed: Sim seconds per wall second (``math.inf``: as fast as possible).
        fps: Frames the page is sent at most per wall second while the run goes.
        announce: Print the page's URL on stderr.
        foxglove_port: Also serve the Foxglove WebSocket protocol on this port (0: any free one; None: not at all);
            see :mod:`robokit.live.foxglove_bridge`.

    Raises:
        UserError: The address cannot be served (the port is taken).
    """

    kind = "monitor"
    period = 1

    def __init__(self, host: str = "127.0.0.1", port: int = 0, *, paused: bool = False, speed: float = 1.0,
                 fps: float = 30.0, announce: bool = True, foxglove_port: int | None = None) -> None:
        self.host, self.port = host, port
        self.publisher = Publisher()
        self.control = Control(paused=paused, speed=speed)
        self.keys = PageKeys()
        self.fps = fps
        self.sim: Any = None
        self.links: list[Any] = []
        """The drawn links (:class:`robokit.record.replay.Link`), in the order of a frame's ``poses``."""
        self._states: dict[str, str] = {}
        self._recent: deque[dict[str, Any]] = deque(maxlen=TRANSITIONS_KEPT)
        self._next = 0.0
        self.outcome: dict[str, Any] | None = None
        from robokit.live.server import LiveServer

        try:
            self.server: Any = LiveServer(self, host=host, port=port)
        except OSError as exc:
            raise UserError(f"--live: cannot serve on {host}:{port}: {exc.strerror or exc} (choose another port with "
                            f"--live-port, 0 for any free one)") from None
        self.url = self.server.url
        self.foxglove: Any = None
        if foxglove_port is not None:
            from robokit.live.foxglove_bridge import FoxgloveBridge

            self.foxglove = FoxgloveBridge(self, host, foxglove_port)
        if announce:
            print(f"robokit: live view at {self.url}", file=sys.stderr, flush=True)
            if self.foxglove is not None:
                print(f"robokit: Foxglove live at {self.foxglove.url} (Foxglove app: open connection, Foxglove "
                      f"WebSocket)", file=sys.stderr, flush=True)

    # ----------------------------------------------------------------- lifecycle hooks
    @hookimpl
    def robokit_run_start(self, simulation: Any) -> None:
        """Build the page's scene from the world as it starts, start serving, join the loop."""
        if simulation.world.engine != "pybullet":
            raise UserError(f"--live draws PyBullet worlds; this run's engine is {simulation.world.engine!r}")
        from robokit.record.layout import machines_of

        self.sim = simulation
        scene, self.links = scene_payload(simulation)
        machines = machines_of(simulation.behaviour)
        self._states = {m["name"]: m["initial"] for m in machines}
        for comp in simulation.components.values():
            if hasattr(comp, "key_source"):
                comp.key_source = self.keys
        simulation.trace_listeners.append(self._on_trace)
        simulation.add_monitor(self)
        self._publish()
        self.server.scene, self.server.machines = scene, machines
        folder = getattr(simulation, "run_dir", None)
        self.server.run = {"id": simulation.run_id, "folder": str(folder) if folder is not None else None}

    @hookimpl
    def robokit_run_end(self, simulation: Any, result: Any) -> None:
        """Publish the last frame with the run's outcome."""
        self.outcome = {"outcome": result.outcome, "reason": result.reason}
        self._publish()

    # ----------------------------------------------------------------- the loop's side
    def sample(self, tick: int) -> None:
        """At the start of every tick: a frame if one is due, then pause / step / real-time pacing."""
        now = time.perf_counter()
        if now >= self._next:
            self._next = now + 1.0 / self.fps
            self._publish()
        self.control.gate(self.sim.world.time, self._stopped, self._publish)

    def _stopped(self) -> bool:
        return bool(self.sim.interrupted)

    def _on_trace(self, record: dict[str, Any]) -> None:
        if record.get("kind") == "transition":
            self._states[record.get("machine", "")] = record.get("dest_state", "")
        if record.get("kind") in ("transition", "event") or "composite" in record or "monitor" in record:
            self._recent.append({k: v for k, v in record.items() if isinstance(v, (str, int, float, bool))})

    def frame(self) -> dict[str, Any]:
        """The state now: tick, sim time ``t`` (s), link ``poses`` (see :func:`link_poses`), each machine's state,
        the latest transitions, the controls, and the ``outcome`` once the run has ended."""
        world = self.sim.world
        return {"tick": world.tick, "t": round(world.time, 6), "poses": link_poses(world, self.links),
                "states": dict(self._states), "recent": list(self._recent), **self.control.state(),
                "outcome": self.outcome}

    def _publish(self) -> None:
        self.publisher.put(self.frame())

    # ----------------------------------------------------------------- end
    def close(self, grace: float = 1.0) -> None:
        """Stop serving; first give open pages up to ``grace`` wall seconds to receive the last frame."""
        if self.server is not None:
            self.server.drain(self.publisher.seq, grace)
            self.server.stop()
            self.server = None
        self.publisher.close()
        if self.foxglove is not None:
            self.foxglove.stop()
            self.foxglove = None
