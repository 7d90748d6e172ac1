"""``--gui-hold`` on a virtual display: the outcome is printed when the run ends (before the window is held), and
Ctrl-C in the held window closes it keeping the run's own exit code (SIGTERM still ends robokit with 143)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

SCENE = """
[world]
max_time = 0.25

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [0, 0, 0.5]
"""

pytestmark = pytest.mark.slow


def held_run(folder: Path, sig: signal.Signals, display: dict[str, str],
             engine: str = "pybullet") -> tuple[int, list[str], str, str]:
    """Start a held GUI run; once robokit says the window is held, send ``sig`` to it. Returns the exit code, the
    stdout lines printed before the signal, all stdout and stderr."""
    scene = folder / "scene.toml"
    scene.write_text(SCENE)
    proc = subprocess.Popen([sys.executable, "-m", "robokit.cli", "run", str(scene), "--gui", "--gui-hold",
                             "--engine", engine],
                            cwd=folder, env=display, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stderr is not None
    out_lines: list[str] = []
    outcome_seen = threading.Event()

    def read_stdout() -> None:
        for line in proc.stdout:  # type: ignore[union-attr]
            out_lines.append(line)
            if line.startswith("outcome:"):
                outcome_seen.set()

    reader = threading.Thread(target=read_stdout, daemon=True)
    reader.start()
    err_lines: list[str] = []
    for line in proc.stderr:  # wait for robokit's own word that the window is held
        err_lines.append(line)
        if "the window stays open" in line:
            break
    else:
        proc.wait(timeout=60)
        pytest.fail("the window was never held: " + "".join(err_lines)[-2000:])
    outcome_seen.wait(60)  # already printed (flushed) before the hold message: this only lets the reader catch up
    assert proc.poll() is None  # still holding the window
    before = list(out_lines)
    os.kill(proc.pid, sig)  # robokit itself (no xvfb-run between), as Ctrl-C or `kill` would
    rest = proc.stderr.read()
    proc.wait(timeout=120)
    reader.join(60)
    return proc.returncode, before, "".join(out_lines), "".join(err_lines) + rest


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])  # MuJoCo's window: its own viewer
def test_ctrl_c_in_the_held_window_keeps_the_runs_exit_code_and_the_outcome_came_first(
        tmp_path: Path, virtual_display: dict[str, str], engine: str) -> None:
    code, before, out, err = held_run(tmp_path, signal.SIGINT, virtual_display, engine)
    assert code == 0, err[-2000:]
    assert any(line.startswith("outcome: succeeded") for line in before), before  # printed before holding
    assert "interrupted" not in err and "Traceback" not in err
    (run,) = (tmp_path / "results").iterdir()
    assert json.loads((run / "result.json").read_text())["outcome"] == "succeeded"


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_sigterm_in_the_held_window_ends_robokit_with_143(tmp_path: Path, virtual_display: dict[str, str],
                                                         engine: str) -> None:
    code, before, _out, err = held_run(tmp_path, signal.SIGTERM, virtual_display, engine)
    assert code == 143, err[-2000:]
    assert any(line.startswith("outcome: succeeded") for line in before)
    assert "robokit: interrupted (SIGTERM)" in err
