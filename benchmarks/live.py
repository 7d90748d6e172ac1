"""What ``robokit run --live`` costs the loop: process CPU time per tick of the main job with and without the live
view, interleaved in one process.

Each pair runs ``configs/sort_robot.toml`` for ``--sim`` seconds (build and close outside the timing) once plainly
and once with a live view at full speed (``as fast as possible``: pacing's sleeps would hide the cost) and one page
reading its event stream (a socket in a thread of this process that reads and discards the frames, so the server's
work of encoding and sending them is counted too). CPU time is the whole process's (``time.process_time``: every
thread), from the first tick to the last (the live view builds its scene once, before the first tick: printed
apart). Both runs of a pair must end identically (ticks, outcome, result). Prints each pair and the ratio of the
medians, and the machine's load.

With ``--sensors a,b`` the page asks for those sensors' readings (``/events?sensors=a,b``) and fetches each camera's
image as a page does (``/camera/NAME``, five times a wall second), so the sensor payload and the JPEG encoding are
counted too.

    python benchmarks/live.py [--repeats 5] [--sim 6] [--config configs/sort_robot.toml] [--sensors camera,arm]
"""

from __future__ import annotations

import argparse
import math
import os
import socket
import statistics
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from robokit import hookimpl
from robokit.config import load_config
from robokit.core.simulation import Simulation
from robokit.live import LiveView
from robokit.plugin_api.plugins import load_plugins

CONFIG = Path(__file__).resolve().parent.parent / "configs" / "sort_robot.toml"


def _reader(url: str, stop: threading.Event, sensors: str) -> None:
    """A page that reads every frame it is sent and throws it away."""
    parts = urlsplit(url)
    query = f"?sensors={sensors}" if sensors else ""
    with socket.create_connection((parts.hostname, parts.port)) as sock:
        sock.sendall(f"GET /events{query} HTTP/1.1\r\nHost: {parts.netloc}\r\n\r\n".encode())
        sock.settimeout(0.5)
        while not stop.is_set():
            try:
                if not sock.recv(65536):
                    return
            except TimeoutError:
                continue


def _images(url: str, stop: threading.Event, cameras: list[str]) -> None:
    """A page showing ``cameras``: each one's latest image, five times a wall second."""
    import urllib.error
    import urllib.request

    while not stop.wait(0.2):
        for name in cameras:
            try:
                with urllib.request.urlopen(f"{url}camera/{name}", timeout=5) as reply:
                    reply.read()
            except urllib.error.HTTPError:  # no image yet
                continue


class Clock:
    """Takes the process's CPU time when the loop starts (after every run-start hook: the live view's scene is
    built then, once a run) and when it ends."""

    def __init__(self) -> None:
        self.start = self.end = 0.0

    @hookimpl
    def robokit_run_start(self, simulation: Any) -> None:
        self.start = time.process_time()

    @hookimpl
    def robokit_run_end(self, simulation: Any, result: Any) -> None:
        self.end = time.process_time()


def one(sim_seconds: float, live: bool, config: Path = CONFIG, sensors: str = "") -> tuple[float, float, Any]:
    """CPU seconds per tick of one run's loop, CPU seconds of its start (run start to the first tick), its result."""
    plugins = load_plugins()
    clock = Clock()
    plugins.pm.register(clock, name="benchmark-clock")  # before the view: its hooks run after the view's
    view = None
    if live:
        view = LiveView("127.0.0.1", 0, speed=math.inf, announce=False)
        plugins.pm.register(view, name="robokit-live")
    cfg = load_config(config, plugins)
    stop = threading.Event()
    with Simulation(cfg, plugins) as sim:
        readers = []
        if view is not None:
            kinds = {s.name: s.type for s in cfg.sensors}
            cameras = [n for n in sensors.split(",") if kinds.get(n) == "camera"]
            readers = [threading.Thread(target=_reader, args=(view.url, stop, sensors), daemon=True),
                       threading.Thread(target=_images, args=(view.url, stop, cameras), daemon=True)]
            for reader in readers:
                reader.start()
        c0 = time.process_time()
        result = sim.run(max_time=sim_seconds)
        stop.set()
        for reader in readers:
            reader.join(2)
    if view is not None:
        view.close(grace=0)
    return (clock.end - clock.start) / max(1, result.ticks), clock.start - c0, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--sim", type=float, default=6.0, help="sim seconds per run")
    ap.add_argument("--config", type=Path, default=CONFIG)
    ap.add_argument("--sensors", default="", help="sensors the page asks for, comma-separated")
    args = ap.parse_args()
    one(0.5, False, args.config)  # warm-up: imports, caches
    plain, live, starts = [], [], []
    for i in range(args.repeats):
        a, _, ra = one(args.sim, False, args.config)
        b, start, rb = one(args.sim, True, args.config, args.sensors)
        starts.append(start)
        same = (ra.ticks, ra.outcome, ra.result) == (rb.ticks, rb.outcome, rb.result)
        if not same:
            raise SystemExit(f"pair {i}: the runs differ: {ra.outcome} {ra.ticks} vs {rb.outcome} {rb.ticks}")
        plain.append(a)
        live.append(b)
        print(f"pair {i}: plain {a * 1e6:.1f} us/tick, live {b * 1e6:.1f} us/tick ({ra.ticks} ticks, same result)")
    ratio = statistics.median(live) / statistics.median(plain)
    print(f"CPU time per tick, live / plain (medians of {args.repeats}): {ratio:.3f}x "
          f"({statistics.median(plain) * 1e6:.1f} -> {statistics.median(live) * 1e6:.1f} us/tick); "
          f"load {os.getloadavg()[0]:.1f}")
    print(f"the live view's start (its scene built from the world), once a run: "
          f"{statistics.median(starts) * 1e3:.0f} ms CPU")


if __name__ == "__main__":
    main()
