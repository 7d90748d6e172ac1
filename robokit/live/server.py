"""The live page's HTTP server: the standard library's threading server, in a daemon thread.

Routes (every one needs ``?token=...`` when the server binds an address other than loopback):

- ``GET /``: the page (three.js, the replay viewer, the scene, ``live.js``, all inline);
- ``GET /state``: the latest frame as JSON (see :meth:`robokit.live.view.LiveView.frame`);
- ``GET /events?sensors=a,b``: the frames as Server-Sent Events, each the latest when the page is ready for it,
  carrying the readings of the sensors named (see :mod:`robokit.live.sensors`);
- ``GET /camera/NAME``: camera ``NAME``'s latest image a frame carried, as JPEG (header ``X-Robokit-Tick``: the
  tick it was rendered at);
- ``POST /control``: ``{"action": "pause" | "resume" | "step" | "speed", "value": ...}`` (``step``: a number of
  ticks, one if absent; ``speed``: "1" | "2" | "max");
- ``POST /key``: ``{"key": "up", "down": true}``, a key pressed or released in the page.
"""

from __future__ import annotations

import hmac
import json
import secrets
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

DATA = Path(__file__).resolve().parent.parent / "data"
LOOPBACK = ("127.0.0.1", "localhost", "::1")
KEEPALIVE = 10.0
"""Seconds between comment lines on an idle event stream (a closed page is noticed then)."""


class LiveServer:
    """Serves one live view (:class:`robokit.live.view.LiveView`) on ``host:port`` until :meth:`stop`."""

    def __init__(self, view: Any, *, host: str = "127.0.0.1", port: int = 0) -> None:
        self.view = view
        self.scene: dict[str, Any] | None = None
        """The replay viewer's payload of the run's world (set when the run starts)."""
        self.machines: list[dict[str, Any]] = []
        self.sensors: list[dict[str, Any]] = []
        """What the page offers to pick (:meth:`robokit.live.sensors.SensorFeed.describe`)."""
        self.run: dict[str, Any] = {}
        """The run's ``id`` and record ``folder`` (None when the run keeps no record)."""
        self.token = None if host in LOOPBACK else secrets.token_urlsafe(16)
        self.streams: dict[int, int] = {}
        """Open event streams: thread id -> the last frame number sent."""
        self._lock = threading.Condition()  # notified when a stream has sent a frame (drain waits on it)
        self._page_scene: tuple[Any, dict[str, Any]] | None = None  # the scene, and it with its meshes read
        self.httpd = ThreadingHTTPServer((host, port), _handler(self))
        self.httpd.daemon_threads = True
        self.port = self.httpd.server_address[1]
        shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host  # noqa: S104 - only names what was asked for
        self.url = f"http://{shown}:{self.port}/" + (f"?token={self.token}" if self.token else "")
        self._thread = threading.Thread(target=self.httpd.serve_forever, args=(0.1,), name="robokit-live",
                                        daemon=True)  # polls for stop() every 0.1 s
        self._thread.start()

    def page(self) -> str:
        from robokit.record.replay import REPLAY_CSS, REPLAY_SCRIPT, replay_markup, viewer_script

        def inline(text: str) -> str:
            return text.replace("</script", "<\\/script")

        from robokit.live.scene import add_meshes

        with self._lock:
            if self._page_scene is None or self._page_scene[0] is not self.scene:
                self._page_scene = (self.scene, add_meshes(self.scene or {}))
            scene = self._page_scene[1]
        three = viewer_script() or ""
        sim = self.view.sim
        data = json.dumps({"scene": scene, "machines": self.machines, "run": self.run, "sensors": self.sensors,
                           "picked": list(self.view.picked), "time_step": sim.world.time_step if sim else 0.0},
                          separators=(",", ":"))
        template = (DATA / "live" / "index.html").read_text(encoding="utf-8")
        return (template.replace("/*REPLAY_CSS*/", REPLAY_CSS).replace("<!--REPLAY-->", replay_markup())
                .replace("/*THREE*/", inline(three))
                .replace("/*DATA*/", "var RK_LIVE = " + data.replace("</", "<\\/") + ";"
                         " var RK_REPLAY = RK_LIVE.scene;")
                .replace("/*REPLAY_JS*/", inline(REPLAY_SCRIPT.read_text(encoding="utf-8")))
                .replace("/*LIVE_JS*/", inline((DATA / "live" / "live.js").read_text(encoding="utf-8"))))

    def allowed(self, query: dict[str, list[str]]) -> bool:
        if self.token is None:
            return True
        given = (query.get("token") or [""])[0]
        return hmac.compare_digest(given.encode(), self.token.encode())

    def sent(self, stream: int, seq: int | None) -> None:
        with self._lock:
            if seq is None:
                self.streams.pop(stream, None)
            else:
                self.streams[stream] = seq
            self._lock.notify_all()

    def drain(self, seq: int, grace: float) -> None:
        """Wait up to ``grace`` s for every open stream to have sent frame ``seq`` (the run's last)."""
        with self._lock:
            self._lock.wait_for(lambda: all(s >= seq for s in self.streams.values()), grace)

    def stop(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


def _handler(server: LiveServer) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
            return

        def _reply(self, status: int, body: bytes, kind: str = "application/json") -> None:
            self.send_response(status)
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def _error(self, status: int, message: str) -> None:
            self._reply(status, json.dumps({"error": message}).encode())

        def _route(self) -> tuple[str, dict[str, list[str]]] | None:
            parts = urlsplit(self.path)
            query = parse_qs(parts.query)
            if not server.allowed(query):
                self._error(HTTPStatus.FORBIDDEN, "this live view needs its token (?token=...): see the URL printed")
                return None
            return parts.path, query

        def do_GET(self) -> None:  # noqa: N802 - the base class's name
            route = self._route()
            if route is None:
                return
            path = route[0]
            if path == "/" and server.scene is None:
                self._reply(HTTPStatus.SERVICE_UNAVAILABLE, (b"<meta http-equiv='refresh' content='1'>"
                                                              b"<p>The run is starting: this page reloads itself.</p>"),
                            "text/html; charset=utf-8")
            elif path == "/":
                self._reply(HTTPStatus.OK, server.page().encode(), "text/html; charset=utf-8")
            elif path == "/state":
                frame = server.view.publisher.latest()
                self._reply(HTTPStatus.OK, json.dumps(frame).encode())
            elif path == "/events":
                names = [n for n in ",".join(route[1].get("sensors", [])).split(",") if n]
                feed = server.view.feed
                if names and feed is not None:
                    try:
                        feed.ask(threading.get_ident(), names)
                    except ValueError as exc:
                        self._error(HTTPStatus.BAD_REQUEST, f"?sensors=: {exc}")
                        return
                self._stream()
            elif path.startswith("/camera/"):
                self._camera(path[len("/camera/"):])
            else:
                self._error(HTTPStatus.NOT_FOUND, f"no such page: {path}")

        def _camera(self, name: str) -> None:
            feed = server.view.feed
            kind = None if feed is None else feed.kinds.get(name)
            if kind != "image":
                self._error(HTTPStatus.NOT_FOUND, f"no camera {name!r} in this run")
                return
            got = feed.jpeg(name)
            if got is None:
                self._error(HTTPStatus.NOT_FOUND, f"camera {name!r} has no image yet (the run renders it when "
                                                  f"something reads it, and a page asked for it)")
                return
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-Type", "image/jpeg")
            self.send_header("Content-Length", str(len(got[1])))
            self.send_header("X-Robokit-Tick", str(got[0]))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(got[1])

        def _stream(self) -> None:
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-Type", "text/event-stream")
            self.send_header("Cache-Control", "no-store")
            self.send_header("Connection", "close")
            self.end_headers()
            self.close_connection = True
            me, seen, publisher = threading.get_ident(), 0, server.view.publisher
            server.sent(me, 0)
            try:
                while not publisher.closed:
                    frame = publisher.take(seen, KEEPALIVE)
                    if frame is None:
                        self.wfile.write(b": idle\n\n")
                    else:
                        seen = frame["seq"]
                        self.wfile.write(b"data: " + json.dumps(frame, separators=(",", ":")).encode() + b"\n\n")
                        server.sent(me, seen)
                    self.wfile.flush()
            except OSError:  # the page was closed
                pass
            finally:
                server.sent(me, None)
                if server.view.feed is not None:
                    server.view.feed.ask(me, None)

        def do_POST(self) -> None:  # noqa: N802 - the base class's name
            route = self._route()
            if route is None:
                return
            try:
                length = int(self.headers.get("Content-Length") or 0)
                body = json.loads(self.rfile.read(min(length, 4096)) or b"{}")
                if not isinstance(body, dict):
                    raise ValueError("expected a JSON object")
                if route[0] == "/control":
                    server.view.control.apply(str(body.get("action", "")), str(body.get("value", "")))
                elif route[0] == "/key":
                    server.view.keys.press(str(body.get("key", "")), bool(body.get("down", True)))
                else:
                    self._error(HTTPStatus.NOT_FOUND, f"no such endpoint: {route[0]}")
                    return
            except ValueError as exc:
                self._error(HTTPStatus.BAD_REQUEST, str(exc))
                return
            self._reply(HTTPStatus.OK, json.dumps(server.view.control.state()).encode())

    return Handler
