"""A real HTTP server on 127.0.0.1 for the reporting tests: records every request, answers by a plan.

It behaves like a course server that honours ``Idempotency-Key``: the first request with a key that reaches the
"store" point is stored; later ones with the same key are answered 200 with the stored copy and not stored again.
``requests`` counts every request that arrived (the raw count), ``stored`` holds one payload per key.
"""

from __future__ import annotations

import json
import socket
import ssl
import struct
import subprocess
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from robokit.core.result import RunResult
from robokit.report.reporting import build_payload


@dataclass(frozen=True)
class Answer:
    """What the server does with one request.

    ``reset``: drop the connection with a TCP reset before answering (a refusal seen by the client as a
    connection error). ``stall``: never answer until the server stops (the client's read timeout fires).
    ``store``: store the payload (first time per key) before answering or stalling.
    """

    status: int = 201
    body: str = '{"ok": true}'
    headers: tuple[tuple[str, str], ...] = ()
    store: bool = True
    stall: bool = False
    reset: bool = False


@dataclass
class Recorded:
    """One request as it arrived."""

    path: str
    headers: dict[str, str]
    body: bytes
    at: float
    answer: Answer
    after_ack: bool = False
    """The server had already answered 2xx to a request with this key when this one arrived."""

    @property
    def key(self) -> str | None:
        return self.headers.get("idempotency-key")

    def json(self) -> Any:
        return json.loads(self.body)


@dataclass
class CourseServer:
    """``plan(n)`` decides the n-th request's answer (n from 0); ``on_request`` runs after recording."""

    plan: Callable[[int], Answer] = lambda n: Answer()
    on_request: Callable[[Recorded], None] | None = None
    requests: list[Recorded] = field(default_factory=list)
    stored: dict[str, Any] = field(default_factory=dict)
    store_count: dict[str, int] = field(default_factory=dict)
    acked: set[str] = field(default_factory=set)
    tls: tuple[str, str] | None = None
    """(certificate file, key file): serve HTTPS."""

    def __post_init__(self) -> None:
        self._lock = threading.Lock()
        self.release = threading.Event()
        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), _handler_for(self))
        self._httpd.daemon_threads = True
        if self.tls is not None:
            ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
            ctx.load_cert_chain(*self.tls)
            self._httpd.socket = ctx.wrap_socket(self._httpd.socket, server_side=True)
        self._thread = threading.Thread(target=self._httpd.serve_forever, kwargs={"poll_interval": 0.05},
                                        daemon=True)

    @property
    def url(self) -> str:
        host, port = self._httpd.server_address[:2]
        scheme = "https" if self.tls else "http"
        return f"{scheme}://{host}:{port}/api/robotics/result/"

    def start(self) -> CourseServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self.release.set()
        self._httpd.shutdown()
        self._httpd.server_close()

    def script(self, *answers: Answer, then: Answer = Answer()) -> None:
        """Answer the next requests with ``answers`` in order, then with ``then``."""
        start = len(self.requests)
        self.plan = lambda n: answers[n - start] if 0 <= n - start < len(answers) else then

    def keys(self) -> list[str | None]:
        return [r.key for r in self.requests]

    def _record(self, path: str, headers: dict[str, str], body: bytes, clock: float) -> Recorded:
        with self._lock:
            answer = self.plan(len(self.requests))
            rec = Recorded(path, headers, body, clock, answer, after_ack=headers.get("idempotency-key") in self.acked)
            self.requests.append(rec)
            if answer.store and not answer.reset and rec.key and rec.key not in self.stored \
                    and (answer.stall or 200 <= answer.status < 300):
                self.stored[rec.key] = rec.json()
                self.store_count[rec.key] = self.store_count.get(rec.key, 0) + 1
        return rec


def _handler_for(server: CourseServer) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        disable_nagle_algorithm = True  # headers and body go out at once (no 40 ms delayed-ACK stalls)

        def do_POST(self) -> None:  # noqa: N802 - http.server's naming
            body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
            headers = {k.lower(): v for k, v in self.headers.items()}
            rec = server._record(self.path, headers, body, time.monotonic())
            if server.on_request is not None:
                server.on_request(rec)
            answer = rec.answer
            if answer.reset:
                self.connection.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                self.close_connection = True
                return
            if answer.stall:
                server.release.wait(30)
                self.close_connection = True
                return
            reply = answer.body.encode()
            try:
                self.send_response(answer.status)
                for name, value in answer.headers:
                    self.send_header(name, value)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(reply)))
                self.end_headers()
                self.wfile.write(reply)
                self.wfile.flush()
            except OSError:  # the client is gone (e.g. killed by a test)
                return
            if 200 <= answer.status < 300 and rec.key:
                with server._lock:
                    server.acked.add(rec.key)

        def log_message(self, *args: Any) -> None:
            pass

    return Handler


def closed_port_url() -> str:
    """A URL on 127.0.0.1 where nothing listens (connections are refused)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}/api/robotics/result/"


class SilentListener:
    """A socket that listens but never accepts: connections succeed, requests are never answered (read timeout)."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}/api/robotics/result/"

    def close(self) -> None:
        self.sock.close()


def make_payload(i: int = 0, **result: Any) -> dict[str, Any]:
    """A RunResult payload with a deterministic run id (no simulation needed)."""
    r = RunResult(run_id=f"00000000-0000-4000-8000-{i:012d}", robokit_version="0.1.0", config="configs/x.toml",
                  behaviour="sort", seed=i, outcome="succeeded", reason="", ticks=240, sim_time=1.0,
                  wall_time=0.1, started_at="2026-01-01T00:00:00+00:00", result=result)
    return build_payload(r, student="kim", project="A")


def self_signed_cert(folder: Path) -> tuple[str, str]:
    """A throwaway certificate for 127.0.0.1 made with the ``openssl`` command: (cert file, key file)."""
    cert, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
                    "-nodes", "-keyout", str(key), "-out", str(cert), "-days", "1", "-subj", "/CN=127.0.0.1",
                    "-addext", "subjectAltName=IP:127.0.0.1"], check=True, capture_output=True)
    return str(cert), str(key)
