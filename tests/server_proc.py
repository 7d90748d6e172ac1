"""Running ``robokit serve`` as a real process for the end-to-end and browser tests."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

ROBOKIT = [sys.executable, "-m", "robokit.cli"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def robokit(*args: str, cwd: Path, env: dict[str, str] | None = None, check: bool = True,
            timeout: float = 600) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run([*ROBOKIT, *args], cwd=cwd, env={**os.environ, **(env or {})}, capture_output=True,
                          text=True, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"robokit {' '.join(args)} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}")
    return proc


class Server:
    """``robokit serve --data DIR --port P`` in a subprocess; its output is collected for checks."""

    def __init__(self, data: Path, port: int, env: dict[str, str] | None = None, extra: tuple[str, ...] = (),
                 workers: int = 0) -> None:
        self.data, self.port, self.extra = data, port, ("--workers", str(workers), *extra)  # no queue unless asked
        self.url = f"http://127.0.0.1:{port}"
        self.env = {**os.environ, **(env or {})}
        self.lines: list[str] = []
        self.proc: subprocess.Popen[str] | None = None

    def start(self) -> Server:
        self.proc = subprocess.Popen([*ROBOKIT, "serve", "--data", str(self.data), "--port", str(self.port),
                                      *self.extra],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=self.env)
        assert self.proc.stdout is not None
        for line in self.proc.stdout:  # blocks until the server says it listens (or exits)
            self.lines.append(line)
            if re.search(r"robokit serve: http://", line):
                break
        else:
            raise AssertionError("robokit serve exited before listening:\n" + "".join(self.lines))
        self._drainer = threading.Thread(target=self._drain, daemon=True)
        self._drainer.start()
        return self

    def _drain(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def stop(self) -> int:
        assert self.proc is not None
        self.proc.terminate()
        code = self.proc.wait(timeout=60)
        self._drainer.join(timeout=60)  # the output ends when the process has exited: read it all
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        return code

    @property
    def log(self) -> str:
        return "".join(self.lines)


def teacher_session(url: str, user: str, password: str) -> Any:
    """A requests session logged in through the real login form (CSRF token included)."""
    import requests

    s = requests.Session()
    page = s.get(f"{url}/accounts/login/", timeout=30)
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text)
    assert token is not None
    resp = s.post(f"{url}/accounts/login/", data={"username": user, "password": password, "next": "/",
                                                  "csrfmiddlewaretoken": token.group(1)},
                  headers={"Referer": f"{url}/accounts/login/"}, timeout=30, allow_redirects=False)
    assert resp.status_code == 302, resp.text[:500]
    return s
