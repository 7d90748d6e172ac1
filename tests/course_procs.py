"""A course server with its queue workers as real processes, for the slow course-work tests: set-up through
``robokit manage``, submissions over HTTP, the server's database read back directly.

The database is SQLite in the data folder, or, when ``DATABASE_URL`` names a PostgreSQL server (as .ci/run's
PostgreSQL pass sets it), a new database of its own on that server for each :class:`CourseServer`: the same tests
run on both."""

from __future__ import annotations

import os
import re
import sqlite3
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import psutil
from server_proc import ROBOKIT, free_port, robokit

PASSWORD = "correct-horse-battery"


class CourseServer:
    """``robokit serve --workers N`` in its own process group (so the whole server, workers and sandboxes
    included, can be SIGKILLed at once, as a power cut would)."""

    def __init__(self, data: Path, workers: int = 1, env: dict[str, str] | None = None) -> None:
        self.data, self.workers, self.port = data, workers, free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.env = {**os.environ, "ROBOKIT_TEACHER_PASSWORD": PASSWORD, **(env or {})}
        self.database = fresh_database(self.env.get("DATABASE_URL", ""))
        if self.database:
            self.env["DATABASE_URL"] = self.database
        self.lines: list[str] = []
        self.proc: subprocess.Popen[str] | None = None

    def manage(self, *args: str) -> str:
        return robokit("manage", "--data", str(self.data), *args, cwd=self.data.parent, env=self.env).stdout

    def start(self) -> CourseServer:
        self.proc = subprocess.Popen([*ROBOKIT, "serve", "--data", str(self.data), "--port", str(self.port),
                                      "--workers", str(self.workers)], stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, env=self.env, start_new_session=True)
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)
            if "Cluster" in line and "running" in line:  # the queue's workers are up
                break
            if self.workers == 0 and line.startswith("robokit serve: http://"):  # no workers: listening is all
                break
        else:
            raise AssertionError("robokit serve exited before its workers ran:\n" + self.log)
        self._drainer = threading.Thread(target=self._drain, daemon=True)
        self._drainer.start()
        return self

    def _drain(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    @property
    def log(self) -> str:
        return "".join(self.lines)

    def tree(self) -> list[psutil.Process]:
        """The server and every process under it (its worker, the queue's processes, sandboxes)."""
        assert self.proc is not None
        try:
            top = psutil.Process(self.proc.pid)
            return [top, *top.children(recursive=True)]
        except psutil.NoSuchProcess:
            return []

    def kill(self) -> None:
        """SIGKILL the server's whole process tree at once, as a power cut would: server, worker, queue processes,
        sandboxes (each in a session of its own)."""
        assert self.proc is not None
        tree = self.tree()
        for p in tree:
            p.suspend()  # none of them acts on another's death while the others are killed
        for p in tree:
            p.kill()
        self.proc.wait(timeout=60)
        psutil.wait_procs(tree, timeout=60)

    def stop(self) -> list[psutil.Process]:
        """SIGTERM the server and wait for it; returns the processes of its tree still alive after that (killed
        then: nothing of ours may outlive the test)."""
        assert self.proc is not None
        tree = self.tree()
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=120)
        alive = [p for p in tree if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
        for p in alive:
            p.kill()
        self._drainer.join(timeout=60)  # the output ends when every process that shares it has ended
        return alive

    def query(self, sql: str, *params: Any) -> list[tuple[Any, ...]]:
        """Rows of ``sql`` (``?`` placeholders) from the server's database."""
        if self.database:
            import psycopg

            with psycopg.connect(self.database, autocommit=True) as pg:
                return pg.execute(sql.replace("?", "%s"), params).fetchall()
        with sqlite3.connect(self.data / "db.sqlite3", timeout=30) as db:
            return db.execute(sql, params).fetchall()

    def wait_for(self, what: str, predicate: Callable[[], bool], seconds: float) -> float:
        """Check ``predicate`` until it holds (between checks, wait on the server process: a dead server ends
        the wait at once). Returns the seconds it took."""
        assert self.proc is not None
        start = time.monotonic()
        while not predicate():
            if time.monotonic() - start > seconds:
                raise AssertionError(f"after {seconds:g} s: not yet {what}\n" + self.log[-3000:])
            try:
                code = self.proc.wait(timeout=0.25)
            except subprocess.TimeoutExpired:
                continue
            raise AssertionError(f"robokit serve exited ({code}) while waiting for {what}:\n{self.log[-3000:]}")
        return time.monotonic() - start


def fresh_database(url: str) -> str:
    """For a PostgreSQL ``url``: a new, empty database on that server (its role may create databases), as a URL;
    for anything else: ""."""
    if not url.startswith(("postgres://", "postgresql://")):
        return ""
    import uuid

    import psycopg

    name = f"robokit_{uuid.uuid4().hex[:16]}"
    with psycopg.connect(url, autocommit=True) as pg:
        pg.execute(f'CREATE DATABASE "{name}"')
    return f"{url.rsplit('/', 1)[0]}/{name}"


def setup_class(server: CourseServer, students: list[str]) -> dict[str, str]:
    """A teacher, class 1반 and its students; returns each student's token."""
    robokit("serve", "--data", str(server.data), "--create-teacher", "teacher", cwd=server.data.parent,
            env=server.env)
    server.manage("create_class", "1반", "--teacher", "teacher")
    out = server.manage("add_students", "1반", *students)
    return dict(re.findall(r"^(\S+)\t(rks_\S+)$", out, flags=re.M))
