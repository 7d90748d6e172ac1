"""Signals are handled from the console script's first instruction: SIGINT / SIGTERM at any moment after
``robokit.entry`` started end in 130 / 143, one line on stderr, and an ``aborted`` result of the run.

The oracle for "robokit's code is running" is the kernel's: ``/proc/<pid>/status`` lists the signals a process
catches (``SigCgt``), and Python itself never catches SIGTERM, so SIGTERM caught means ``robokit.entry`` has
installed its handlers. A signal sent while it was not caught yet (the interpreter's own start-up: loading Python
and the environment's ``site`` files, before any robokit code) is only counted, never judged.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROBOKIT = str(Path(sys.prefix) / "bin" / "robokit")
CONFIG = """
[world]
max_time = 3001

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[behaviour]
type = "record"
components = []
duration = 3000
"""
"""A run long enough (seconds of wall time) that every signal of the sweep arrives before it ends."""


def _catches_sigterm(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigCgt:")), 16)
    return bool(mask >> (signal.SIGTERM - 1) & 1)


def _shot(folder: Path, sig: signal.Signals, delay: float, *, after_guard: bool) -> tuple[bool, str]:
    """Start ``robokit run``, send ``sig`` ``delay`` seconds after the spawn (or after the guard appears); returns
    (whether robokit's handlers were installed when the signal was sent, what went wrong or "")."""
    for old in folder.glob("results/*/result.json"):
        old.unlink()
    proc = subprocess.Popen([ROBOKIT, "run", "tiny.toml", "--pose-hz", "0"], cwd=folder, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    start = time.monotonic()
    if after_guard:
        while not _catches_sigterm(proc.pid) and time.monotonic() - start < 30:
            pass
        start = time.monotonic()
    while time.monotonic() - start < delay:
        pass
    guarded = _catches_sigterm(proc.pid)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=120)
    if not guarded:
        return False, ""
    want = 130 if sig == signal.SIGINT else 143
    lines = stderr.strip().splitlines()
    outcomes = [json.loads(p.read_text())["outcome"] for p in folder.glob("results/*/result.json")]
    if proc.returncode != want or len(lines) != 1 or not lines[0].startswith(f"robokit: interrupted ({sig.name})") \
            or outcomes != ["aborted"]:
        return True, f"{sig.name} at {delay * 1000:.0f} ms: exit {proc.returncode}, results {outcomes}, {lines[:3]}"
    return True, ""


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("signals")
    (path / "tiny.toml").write_text(CONFIG)
    return path


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_right_after_the_guard_appears_is_handled(folder: Path, sig: signal.Signals) -> None:
    guarded, problem = _shot(folder, sig, 0.0, after_guard=True)  # robokit.cli is still being imported
    assert guarded and problem == ""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signals_from_spawn_are_handled_once_robokit_runs(folder: Path, sig: signal.Signals) -> None:
    delays = (0.1, 0.3) if sig == signal.SIGINT else (0.2,)  # a subset; the slow sweep tries every 10 ms
    problems = [p for d in delays for g, p in [_shot(folder, sig, d, after_guard=False)] if p]
    assert problems == []


@pytest.mark.slow
def test_the_full_sweep_under_load(folder: Path) -> None:
    """0, 10, ... 300 ms after spawn (and 0, 30, ... 300 ms after robokit's handlers appear), both signals, with two
    busy processes competing for the cores."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    try:
        counts = {"handled": 0, "before robokit": 0}
        problems = []
        for sig in (signal.SIGINT, signal.SIGTERM):
            for ms in range(0, 310, 10):
                for after_guard in (False, True) if ms % 30 == 0 else (False,):
                    guarded, problem = _shot(folder, sig, ms / 1000, after_guard=after_guard)
                    counts["handled" if guarded else "before robokit"] += 1
                    if problem:
                        problems.append(problem)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    print(f"signal sweep under load ({os.getloadavg()[0]:.1f}): {counts}")
    assert problems == [] and counts["handled"] >= 22  # every shot after robokit's first instruction: handled


INJECT = """
import os, signal, sys, time
from robokit import entry
import robokit.runner as runner

real = runner._reserve


def reserve_then_signal(run_dir):
    held = real(run_dir)
    os.kill(os.getpid(), signal.SIGINT)
    end = time.monotonic() + 10
    while time.monotonic() < end:  # start-up's grace runs out here: the guard breaks in while the folder is made
        pass
    return held


runner._reserve = reserve_then_signal
sys.argv = ["robokit", "run", "tiny.toml", "--pose-hz", "0"]
sys.exit(entry.main())
"""


def test_a_forced_break_while_the_run_folder_is_made_keeps_an_aborted_result(tmp_path: Path) -> None:
    """A signal whose start-up grace runs out while ``run_config`` is still making the run's folder (before the run
    keeps anything itself): exit 130, one line, one ``aborted`` result, and no half-made run folder left."""
    (tmp_path / "tiny.toml").write_text(CONFIG)
    proc = subprocess.run([sys.executable, "-c", INJECT], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 130 and len(lines) == 1 and lines[0].startswith("robokit: interrupted (SIGINT)"), \
        proc.stderr
    folders = list((tmp_path / "results").iterdir())
    assert len(folders) == 1, folders
    assert json.loads((folders[0] / "result.json").read_text())["outcome"] == "aborted"
