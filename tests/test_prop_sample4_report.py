"""Report promises judged on a real loopback HTTP server: a submit resent after a lost connection carries the one
Idempotency-Key it started with (however often it is resent, one submission), and an artifact upload's summary line
never shows the bearer token, even when the server echoes it back."""

from __future__ import annotations

import argparse
import json
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from robokit.report import artifact_upload, submit


class _Server(ThreadingHTTPServer):
    daemon_threads = True

    def handle_error(self, request, client_address):  # a connection cut on purpose is not an error here
        pass


def _serve(handler):
    server = _Server(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.01}, daemon=True)
    thread.start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


@pytest.mark.parametrize("lost", [1, 2])
def test_a_resent_submit_keeps_its_idempotency_key(tmp_path, monkeypatch, lost):
    keys: list[str] = []

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def do_POST(self):
            self.rfile.read(int(self.headers.get("Content-Length") or 0))
            keys.append(self.headers.get("Idempotency-Key"))
            if len(keys) <= lost:  # stored, but the answer is lost: the connection drops
                self.close_connection = True
                self.request.shutdown(socket.SHUT_RDWR)
                return
            body = json.dumps({"id": 7, "assignment": "a1", "student": "kim", "seeds": 3}).encode()
            self.send_response(201)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    server, url = _serve(Handler)
    try:
        config = tmp_path / "c.toml"
        config.write_text("[world]\nseed = 1\n", encoding="utf-8")
        monkeypatch.setenv("SAMPLE4_TOKEN", "rks_abc")
        monkeypatch.setattr(submit.time, "sleep", lambda s: None)
        args = argparse.Namespace(url=url, token_env="SAMPLE4_TOKEN", config=str(config), plugin=None,
                                  assignment="a1", wait=False, wait_seconds=1.0)
        assert submit.cmd_submit(args) == 0
    finally:
        server.shutdown()
        server.server_close()
    assert len(keys) == lost + 1  # every send reached the server
    assert keys[0] and len(set(keys)) == 1, keys


def test_an_artifact_refusal_that_echoes_the_token_does_not_show_it(tmp_path):
    token = "rks_s3cret-token-value"

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

        def do_POST(self):
            self.rfile.read(int(self.headers.get("Content-Length") or 0))
            body = f"denied for {self.headers.get('Authorization')}".encode()
            self.send_response(403)
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    server, url = _serve(Handler)
    try:
        f = tmp_path / "result.json"
        f.write_text("{}", encoding="utf-8")
        line = artifact_upload.upload_artifacts(url + "api/robotics/result/", "run1", [("result.json", f)],
                                                token=token)
    finally:
        server.shutdown()
        server.server_close()
    assert "0/1 uploaded" in line and "HTTP 403" in line  # the server's refusal is reported...
    assert token not in line  # ...without the secret it echoed
