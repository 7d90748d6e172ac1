"""docs/server.md's production recipe, run: the SQL that makes the role and the database, on a PostgreSQL server
(the one ``DATABASE_URL`` names, else a throwaway cluster of Debian's postgresql started by ``.ci/postgres``), then
the systemd unit's command with the unit's environment (paths, port and password put in), the teacher made with
the recipe's command, a class and an assignment, a submission graded by the unit's own workers through the host
name and scheme the reverse proxy gives, and ``systemctl stop`` (``KillMode=mixed``: SIGTERM to the main process
alone) ending every process of it.

    python -m pytest -q -s -n 0 -m slow tests/test_course_recipe.py
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import tempfile
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
import requests
from course_procs import PASSWORD
from course_work import OFFICIAL
from server_proc import ROBOKIT, free_port

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "server.md").read_text(encoding="utf-8")
PRODUCTION = DOC[DOC.index("\n## Production\n"):DOC.index("\n## Tests\n")]


def blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", PRODUCTION, flags=re.S)


@pytest.fixture(scope="module")
def postgres() -> Iterator[str]:
    """A superuser's URL on a PostgreSQL server (what ``sudo -u postgres psql`` is in the recipe)."""
    url = os.environ.get("DATABASE_URL", "")
    folder = None
    if not url.startswith(("postgres://", "postgresql://")):
        folder = tempfile.mkdtemp(prefix="robokit-pg-")  # in the shared temporary folder: the postgres user reaches it
        out = subprocess.run([str(ROOT / ".ci" / "postgres"), "start", folder], check=True, capture_output=True,
                             text=True).stdout
        url = out.strip().split("=", 1)[1]
    host = re.sub(r"^\w+://[^@]*@", "", url).split("/", 1)[0]
    try:
        yield f"postgresql://postgres@{host}/postgres"  # the throwaway clusters trust loopback connections
    finally:
        if folder is not None:
            subprocess.run([str(ROOT / ".ci" / "postgres"), "stop", folder], check=True)


def test_the_production_recipe_serves_grades_and_stops(tmp_path: Path, postgres: str) -> None:
    import psycopg

    sql = re.findall(r'sudo -u postgres psql -c "(.*?)"', blocks("sh")[0])
    assert [q.split()[:2] for q in sql] == [["CREATE", "ROLE"], ["CREATE", "DATABASE"]]
    name, secret = f"recipe_{uuid.uuid4().hex[:12]}", uuid.uuid4().hex
    with psycopg.connect(postgres, autocommit=True) as pg:
        for statement in sql:
            pg.execute(statement.replace("robokit", name).replace("SECRET", secret))

    unit = blocks("ini")[0]
    env = dict(re.findall(r"^Environment=(\w+)=(.*)$", unit, flags=re.M))
    command = shlex.split(re.search(r"^ExecStart=(.*)$", unit, flags=re.M).group(1))  # type: ignore[union-attr]
    host = postgres.split("@", 1)[1].split("/", 1)[0]
    port = free_port()
    env["DATABASE_URL"] = env["DATABASE_URL"].replace("robokit", name).replace("SECRET", secret).replace(
        "localhost:5432", host)
    env["ROBOKIT_SERVER_DATA"] = str(tmp_path / "data")
    env["ROBOKIT_SECRET_KEY"] = uuid.uuid4().hex * 2  # the EnvironmentFile's line
    assert command[:2] == ["/srv/robokit/venv/bin/robokit", "serve"] and "--workers" in command
    command = [*ROBOKIT, *command[1:]]
    command[command.index("--port") + 1] = str(port)
    full = {**os.environ, **env, "ROBOKIT_TEACHER_PASSWORD": PASSWORD}

    def manage(*args: str) -> str:
        return subprocess.run([*ROBOKIT, "manage", *args], env=full, check=True, capture_output=True, text=True,
                              timeout=300).stdout

    teacher = re.search(r"robokit manage (create_teacher \w+)", blocks("sh")[1]).group(1)  # type: ignore[union-attr]
    server = subprocess.Popen(command, env=full, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    tree: list[psutil.Process] = []
    try:
        assert server.stdout is not None
        for line in server.stdout:
            if "Cluster" in line and "running" in line:
                break
        tree = [psutil.Process(server.pid), *psutil.Process(server.pid).children(recursive=True)]
        manage(*teacher.split())
        manage("create_class", "1반", "--teacher", "teacher")
        token = re.search(r"(rks_\S+)", manage("add_students", "1반", "김민준")).group(1)  # type: ignore[union-attr]
        official = tmp_path / "official.toml"
        official.write_text(OFFICIAL, encoding="utf-8")
        manage("create_assignment", "1반", "낙하", "--config", str(official), "--seeds", "0:2")
        proxy = {"Host": env["ROBOKIT_ALLOWED_HOSTS"], "X-Forwarded-Proto": "https",
                 "Authorization": f"Bearer {token}"}
        base = f"http://127.0.0.1:{port}/api/robotics/assignments/낙하/submissions/"
        resp = requests.post(base, json={"config": OFFICIAL}, headers=proxy, timeout=60)
        assert resp.status_code == 201, resp.text
        url = f"http://127.0.0.1:{port}/api/robotics/submissions/{resp.json()['id']}/"
        deadline = time.monotonic() + 300
        while (state := requests.get(url, headers=proxy, timeout=60).json())["status"] != "done":
            assert time.monotonic() < deadline and state["status"] in ("queued", "running"), state
            with pytest.raises(subprocess.TimeoutExpired):  # wait on the server: its death ends the test at once
                server.wait(timeout=0.5)
        assert (state["success_rate"], state["wilson95"][1]) == (1.0, 1.0)
        with psycopg.connect(env["DATABASE_URL"]) as db:  # graded in the recipe's own database, by its queue
            assert db.execute("SELECT count(*) FROM course_result WHERE official").fetchone() == (2,)
        tree += [p for p in psutil.Process(server.pid).children(recursive=True) if p not in tree]
    finally:
        server.send_signal(signal.SIGTERM)  # systemctl stop, KillMode=mixed
        code = server.wait(timeout=60)
    gone, alive = psutil.wait_procs(tree, timeout=15)
    assert code == 0 and not alive, alive
