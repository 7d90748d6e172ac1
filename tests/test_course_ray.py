"""Official evaluation on a Ray cluster (``ROBOKIT_RAY_ADDRESS``, slow): the trials go through ``robokit sweep``'s
Ray backend, on the cluster's workers, and give the same official rows as the local sandbox; a submission with the
student's own plugin package too (its files shipped as the Ray job's ``working_dir``), with the same per-trial time
limit.

The cluster is one Ray head on 127.0.0.1 started by the test, with this test's own interpreter
(``python -m ray.scripts.scripts start``, what the ``ray`` command runs): Ray starts its workers with the
interpreter that started the node, so they import the robokit under test also where ``ray`` on the PATH belongs to
another Python (a venv layered on a system site-packages). The two-node behaviour of the backend itself is
tests/test_sweep_ray.py's."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from typing import Any, NamedTuple

import pytest
from course_helpers import Course
from course_work import OFFICIAL, changed, make_assignment, submit
from test_course_student_plugins import MINE, PLUGIN, send

pytest_plugins = ["course_fixtures"]
pytestmark = [pytest.mark.slow, pytest.mark.django_db]
WHERE = PLUGIN["careful_drop/behaviour.py"].replace(
    "        out['careful'] = self.config.care\n",
    "        out['careful'] = self.config.care\n        out['cwd'] = __import__('os').getcwd()\n")
"""The student's plugin, also saying where it ran (its working directory)."""
AGENT_PORTS = ["--dashboard-agent-grpc-port", "--dashboard-agent-listen-port", "--runtime-env-agent-port",
               "--metrics-export-port", "--node-manager-port", "--object-manager-port"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _stop(node: subprocess.Popen[str]) -> None:
    """End exactly this node's process group (never `ray stop`, which stops every Ray on the machine)."""
    for sig, wait in ((signal.SIGTERM, 5), (signal.SIGKILL, 60)):
        try:
            os.killpg(node.pid, sig)
        except ProcessLookupError:
            return
        try:
            node.wait(timeout=wait)
        except subprocess.TimeoutExpired:
            continue
    try:
        os.killpg(node.pid, signal.SIGKILL)  # the leader exited; its group may still hold workers
    except ProcessLookupError:
        pass


class Head(NamedTuple):
    address: str
    temp_dir: str


@pytest.fixture(scope="module")
def ray_head(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Head]:
    """A one-node Ray cluster (2 CPUs) on 127.0.0.1: its ``HOST:PORT`` and its temporary folder. HOME is a fresh
    folder for the node and this driver: a ``~/.ray/auth_token`` left by anyone would switch the cluster to token
    authentication."""
    pytest.importorskip("ray", reason="the Ray backend needs robokit[ray] (in the test extra)")
    temp_dir = tempfile.mkdtemp(prefix="rk", dir="/tmp")  # short: Ray's socket paths must fit 107 bytes
    port = _free_port()
    agents = [a for p in AGENT_PORTS for a in (p, str(_free_port()))]
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HOME", str(tmp_path_factory.mktemp("home")))
        mp.delenv("RAY_AUTH_TOKEN_PATH", raising=False)
        node = subprocess.Popen(
            [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--port", str(port),
             "--node-ip-address", "127.0.0.1", "--num-cpus", "2", "--include-dashboard", "false", "--block",
             "--disable-usage-stats", "--temp-dir", temp_dir, *agents],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
            env={**os.environ, "RAY_TMPDIR": temp_dir, "RAY_raylet_start_wait_time_s": "180",
                 "RAY_agent_register_timeout_ms": "600000"})
        try:
            assert node.stdout is not None
            seen = []
            for line in node.stdout:
                seen.append(line)
                if "Ray runtime started" in line:
                    break
            else:
                raise AssertionError("ray start ended without starting:\n" + "".join(seen[-30:]))
            yield Head(f"127.0.0.1:{port}", temp_dir)
        finally:
            _stop(node)
            shutil.rmtree(temp_dir, ignore_errors=True)


@pytest.fixture
def on_ray(ray_head: Head, settings: Any, monkeypatch: pytest.MonkeyPatch) -> Head:
    settings.QUEUE_SYNC = True
    monkeypatch.setenv("ROBOKIT_RAY_ADDRESS", ray_head.address)
    return ray_head


def _not_here(rows: list[Any]) -> bool:
    """Whether every row's worker (``host:pid``) is another process than this test's."""
    return all(r.payload["worker"].rsplit(":", 1)[1] != str(os.getpid()) for r in rows)


def test_with_a_ray_address_submissions_are_evaluated_on_the_cluster(client: Any, course: Course,
                                                                     on_ray: Head) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0, 1, 2, 3))
    assert submit(client, a.name, changed(OFFICIAL, duration="0.3"), course.kim_token).status_code == 201
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded, sub.success_rate) == ("done", 4, 4, 1.0), sub.error
    rows = list(Result.objects.filter(submission=sub))
    assert sorted(r.seed for r in rows) == [0, 1, 2, 3]
    assert _not_here(rows)  # run by Ray's worker processes
    assert {r.reason for r in rows} == {"watched 33 bodies for 0.3 s"}


def test_a_submission_with_the_students_plugin_is_evaluated_on_the_cluster(client: Any, course: Course,
                                                                           on_ray: Head) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True, seeds=(0, 1, 2))
    config = changed(MINE, duration="0.3").replace("[behaviour]\n", "[behaviour]\ncare = 4\n")
    resp = send(client, a.name, course.kim_token, config, {**PLUGIN, "careful_drop/behaviour.py": WHERE})
    assert resp.status_code == 201, resp.content
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded) == ("done", 3, 3), sub.error
    rows = list(Result.objects.filter(submission=sub))
    assert [r.behaviour for r in rows] == ["careful_drop"] * 3
    assert [r.figures.get("careful") for r in rows] == [4, 4, 4]  # computed by the student's code on Ray
    assert _not_here(rows)
    where = {r.payload["result"]["cwd"] for r in rows}
    assert all(w.startswith(on_ray.temp_dir + os.sep) for w in where), where  # in the job's copy of the files
    assert "careful_drop" not in sys.modules  # the server's process never imported it


def test_on_the_cluster_a_plugin_submissions_trial_keeps_its_time_limit(client: Any, course: Course,
                                                                       on_ray: Head) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*", "world.max_time"], allow_plugins=True,
                        seeds=(0,), trial_seconds=2.0)
    hour = changed(MINE, duration="3600.0", max_time="3700.0")  # an hour of sim time: far past 2 s of CPU time
    assert send(client, a.name, course.kim_token, hour, PLUGIN).status_code == 201
    sub = Submission.objects.get()
    row = Result.objects.get(submission=sub)
    assert row.behaviour == "careful_drop" and _not_here([row])
    assert row.outcome == "aborted" and "its CPU-time budget (2 s of processor time)" in row.reason, row.reason
