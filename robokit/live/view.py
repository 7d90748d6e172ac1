"""The live view's side of the loop: a monitor that publishes the scene, the state machines, the clock and the
readings of the sensors a page picked (:mod:`robokit.live.sensors`), and paces the run to real time (or holds it,
steps it, speeds it up) as the page asks. PyBullet and MuJoCo worlds alike (:mod:`robokit.live.scene`).

It attaches to a run through the lifecycle hooks (:meth:`LiveView.robokit_run_start`), as any plugin may: a monitor
slot in the loop (:meth:`robokit.core.simulation.Simulation.add_monitor`), a trace listener (the same records the run
record writes), and the page's keys handed to every component that takes them (the keyboard sensor's
``key_source``). Frames are taken at most ``fps`` times per wall second, and at every tick while paused.
"""

from __future__ import annotations

import sys
import time
from collections import deque
from typing import Any

from robokit import hookimpl
from robokit.errors import UserError
from robokit.live.publisher import Control, PageKeys, Publisher
from robokit.live.scene import link_poses, scene_payload

TRANSITIONS_KEPT = 12
"""How many of the latest transitions (and composite events) a frame carries."""


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
        sensors: Sensors (or actuators) whose readings every frame carries, besides those a page picks
            (:mod:`robokit.live.sensors`).

    Raises:
        UserError: The address cannot be served (the port is taken).
    """

    kind = "monitor"
    period = 1

    def __init__(self, host: str = "127.0.0.1", port: int = 0, *, paused: bool = False, speed: float = 1.0,
                 fps: float = 30.0, announce: bool = True, foxglove_port: int | None = None,
                 sensors: tuple[str, ...] = ()) -> None:
        self.host, self.port = host, port
        self.picked = tuple(sensors)
        self.feed: Any = None
        """The run's :class:`robokit.live.sensors.SensorFeed` (set when the run starts)."""
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

            try:
                self.foxglove = FoxgloveBridge(self, host, foxglove_port)
            except BaseException:
                self.server.stop()
                raise
        if announce:
            print(f"robokit: live view at {self.url}", file=sys.stderr, flush=True)
            if self.foxglove is not None:
                print(f"robokit: Foxglove live at {self.foxglove.url} (Foxglove app: open connection, Foxglove "
                      f"WebSocket)", file=sys.stderr, flush=True)

    # ----------------------------------------------------------------- lifecycle hooks
    @hookimpl
    def robokit_run_start(self, simulation: Any) -> None:
        """Build the page's scene from the world as it starts, start serving, join the loop."""
        from robokit.live.sensors import SensorFeed
        from robokit.record.layout import machines_of

        self.feed = SensorFeed(simulation.scheduler.slots, self.picked)
        self.sim = simulation
        scene, self.links = scene_payload(simulation)
        machines = machines_of(simulation.behaviour)
        self._states = {m["name"]: m["initial"] for m in machines}
        for comp in simulation.components.values():
            if hasattr(comp, "key_source"):
                comp.key_source = self.keys
        simulation.trace_listeners.append(self._on_trace)
        simulation.add_monitor(self)
        self.server.sensors = self.feed.describe()
        folder = getattr(simulation, "run_dir", None)
        self.server.run = {"id": simulation.run_id, "folder": str(folder) if folder is not None else None}
        self.server.machines = machines
        self.server.scene = scene  # the page is served from now on
        if self.foxglove is not None:
            self.foxglove.add_sensors(self.feed)
        self._publish()  # the first frame: its readers find the scene set

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
        the latest transitions, the controls, the ``outcome`` once the run has ended, and the latest reading of each
        sensor a page picked (``sensors``, only when one did: see :mod:`robokit.live.sensors`)."""
        world = self.sim.world
        frame = {"tick": world.tick, "t": round(world.time, 6), "poses": link_poses(world, self.links),
                 "states": dict(self._states), "recent": list(self._recent), **self.control.state(),
                 "outcome": self.outcome}
        if self.feed.wanted:
            frame["sensors"] = self.feed.payload()
        return frame

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
