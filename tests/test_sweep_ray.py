"""The Ray backend against a real two-node Ray cluster started on 127.0.0.1 by the test (slow): the issue's 2x3 grid
x 4 seeds of pick_place gives per-trial results identical to the local backend's, and faults are errors."""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from test_sweep import FAULT, PLUGINS, stable
from test_sweep_cluster import pick_spec

from robokit.sweep import SweepOptions, SweepRun, SweepSpec, run_sweep

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def local_run(tmp_path_factory: pytest.TempPathFactory) -> SweepRun:
    """The same sweep on the local backend, to compare with."""
    return run_sweep(pick_spec(), SweepOptions(out=tmp_path_factory.mktemp("local") / "out", workers=2))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _ray_node(args: list[str], temp_dir: str) -> subprocess.Popen[str]:
    """``ray start ... --block`` in the foreground, in its own process group: terminating that group stops exactly
    this node's processes (never `ray stop`, which would stop every Ray on the machine). Returns once the node says
    it started. The agents' ports are given (not discovered through port files, which a loaded machine can be too
    slow to write before the raylet gives up)."""
    ray = str(Path(sys.executable).parent / "ray")
    ports = ["--dashboard-agent-grpc-port", "--dashboard-agent-listen-port", "--runtime-env-agent-port",
             "--metrics-export-port", "--node-manager-port", "--object-manager-port"]
    proc = subprocess.Popen([ray, "start", *args, "--node-ip-address", "127.0.0.1", "--num-cpus", "1", "--block",
                             "--disable-usage-stats", *[a for p in ports for a in (p, str(_free_port()))]],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env={**os.environ, "RAY_TMPDIR": temp_dir, "PYTHONPATH": str(PLUGINS),  # --plugin modules
                                 # a loaded machine starts and registers slowly:
                                 "RAY_raylet_start_wait_time_s": "180", "RAY_agent_register_timeout_ms": "600000"})
    assert proc.stdout is not None
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if "Ray runtime started" in line:
            return proc
    _stop_node(proc)
    raise AssertionError("ray start ended without starting:\n" + "".join(seen[-30:]))


def _stop_node(node: subprocess.Popen[str]) -> None:
    """SIGTERM the node's process group (Ray shuts its processes down), then SIGKILL whatever is left of it."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(node.pid, sig)
        except ProcessLookupError:
            return
        try:
            node.wait(timeout=30)
        except subprocess.TimeoutExpired:
            continue
        if sig == signal.SIGTERM:
            try:  # the leader exited; its group may still hold workers
                os.killpg(node.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        return


@pytest.fixture
def ray_cluster(monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A head and a second node on 127.0.0.1, one CPU each; stopped by ending exactly these two process groups.

    HOME is a fresh folder for the nodes and this driver: a ``~/.ray/auth_token`` left by anyone would otherwise
    switch the head to token authentication (Ray enables it when it finds a token) and the second node, without
    it, could not join."""
    pytest.importorskip("ray", reason="the Ray backend needs robokit[ray] (in the test extra)")
    home = tmp_path_factory.mktemp("home")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("RAY_AUTH_TOKEN_PATH", raising=False)
    nodes: list[subprocess.Popen[str]] = []
    temp_dirs: list[str] = []
    try:
        for attempt in range(3):  # on a heavily loaded machine Ray's agents can start too late for the raylet
            temp_dir = tempfile.mkdtemp(prefix="rk", dir="/tmp")  # short: Ray's socket paths must fit 107 bytes
            temp_dirs.append(temp_dir)
            port = _free_port()
            try:
                nodes.append(_ray_node(["--head", "--port", str(port), "--include-dashboard", "false",
                                        "--temp-dir", temp_dir], temp_dir))
                nodes.append(_ray_node(["--address", f"127.0.0.1:{port}"], temp_dir))
                break
            except AssertionError:
                for node in reversed(nodes):
                    _stop_node(node)
                nodes.clear()
                if attempt == 2:
                    raise
        yield f"127.0.0.1:{port}"
    finally:
        for node in reversed(nodes):
            _stop_node(node)
        for folder in temp_dirs:
            shutil.rmtree(folder, ignore_errors=True)


def test_the_ray_backend_on_a_two_node_cluster_gives_the_local_per_trial_results(
        local_run: SweepRun, ray_cluster: str, tmp_path: Path) -> None:
    run = run_sweep(pick_spec(), SweepOptions(out=tmp_path / "out", backend="ray", address=ray_cluster))
    assert len(run.rows) == 24
    diffs = [(a["key"], k, a[k], b[k]) for a, b in zip(stable(run.rows), stable(local_run.rows), strict=True)
             for k in a if a[k] != b[k]]
    assert not diffs, diffs[:5]
    workers: set[Any] = {r["worker"] for r in run.rows}
    assert len(workers) >= 2  # both nodes ran trials


def test_on_ray_a_trial_that_raises_hangs_or_kills_its_worker_is_an_error_and_the_others_finish(
        ray_cluster: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(PLUGINS))  # the driver validates with it; the nodes have it on PYTHONPATH
    spec = SweepSpec(FAULT, range(6), fixed={"behaviour.raise_seeds": [1], "behaviour.hang_seeds": [2],
                                             "behaviour.die_seeds": [3]}, plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", backend="ray", address=ray_cluster, trial_timeout=60))
    by_seed = {r["seed"]: r for r in run.rows}
    assert [by_seed[s]["outcome"] for s in range(6)] == \
        ["succeeded", "error", "error", "error", "succeeded", "succeeded"]
    assert "RuntimeError: fault injected on seed 1" in by_seed[1]["reason"]
    assert by_seed[2]["reason"].startswith("timed out: no result after 60 s (--trial-timeout)")
    assert "worker died twice" in by_seed[3]["reason"]


def test_a_driver_without_ray_auth_mode_is_told_the_address_it_typed_and_to_set_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A head started where ``~/.ray/auth_token`` exists, in token mode: the docs' steps without
    ``RAY_AUTH_MODE=token`` cannot join it, and robokit's one line says so; with it, the same command runs."""
    pytest.importorskip("ray", reason="the Ray backend needs robokit[ray] (in the test extra)")
    home = tmp_path / "home"
    (home / ".ray").mkdir(parents=True)
    (home / ".ray" / "auth_token").write_text("a" * 32 + "\n", encoding="utf-8")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("RAY_AUTH_TOKEN_PATH", raising=False)
    monkeypatch.delenv("RAY_AUTH_TOKEN", raising=False)
    monkeypatch.setenv("RAY_AUTH_MODE", "token")
    temp_dir = tempfile.mkdtemp(prefix="rk", dir="/tmp")
    port = _free_port()
    head = _ray_node(["--head", "--port", str(port), "--include-dashboard", "false", "--temp-dir", temp_dir],
                     temp_dir)
    try:
        command = [sys.executable, "-m", "robokit.cli", "sweep", str(FAULT), "--plugin", "sweep_faults",
                   "--backend", "ray", "--address", f"127.0.0.1:{port}", "--quiet"]
        env = {k: v for k, v in os.environ.items() if k != "RAY_AUTH_MODE"}
        env["PYTHONPATH"] = str(PLUGINS)
        refused = subprocess.run([*command, "--out", str(tmp_path / "a")], capture_output=True, text=True,
                                 env=env, timeout=600)
        assert refused.returncode == 2, refused.stderr[-2000:]
        line = refused.stderr.splitlines()[-1]
        assert line.startswith(f"robokit: error: --address 127.0.0.1:{port}: cannot connect to a Ray cluster"), line
        assert f"a Ray token exists ({home / '.ray' / 'auth_token'})" in line and "RAY_AUTH_MODE=token" in line
        joined = subprocess.run([*command, "--out", str(tmp_path / "b")], capture_output=True, text=True,
                                env={**env, "RAY_AUTH_MODE": "token"}, timeout=600)
        assert joined.returncode == 0, joined.stderr[-2000:]
        assert json.loads((tmp_path / "b" / "summary.json").read_text(encoding="utf-8"))["succeeded"] == 1
    finally:
        _stop_node(head)
        shutil.rmtree(temp_dir, ignore_errors=True)
