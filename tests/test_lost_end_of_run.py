"""The end of a run: the result is kept first and survives what follows (a signal during the pose log, a file-size
limit on the record). Real runs, real files, real signals."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.recorder import Recorder

SCENE = """
[world]
max_time = 2.0
seed = 1

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [0, 0, 1.5]
restitution = 0.8

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0.5, 0, 1.0]

[record]
pose_hz = 240
"""


@pytest.fixture
def scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def only_run(folder: Path) -> Path:
    (run,) = (folder / "results").iterdir()
    return run


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_the_pose_log_is_written_keeps_the_result_written_before_it(
        scene: Path, sig: signal.Signals, monkeypatch: pytest.MonkeyPatch, capsys: Any) -> None:
    """The signal arrives (a real one, to this process) as the pose log is being assembled, after the last tick:
    result.json already exists then, the pose log is finished, no temporary file is left, exit 130 / 143."""
    seen: dict[str, Any] = {}
    original = Recorder.poses

    def poses_then_signal(self: Recorder) -> dict[str, np.ndarray]:
        seen["result_existed"] = (self.folder / "result.json").is_file()
        os.kill(os.getpid(), sig)  # as if Ctrl-C / kill arrived now
        return original(self)

    monkeypatch.setattr(Recorder, "poses", poses_then_signal)
    code = main(["run", str(scene)])
    out, err = capsys.readouterr()
    assert code == 128 + sig
    assert seen == {"result_existed": True}
    run = only_run(scene.parent)
    result = json.loads((run / "result.json").read_text())
    assert result["outcome"] == "succeeded" and result["interrupted"] is False  # the run itself was over
    assert result["ticks"] == 480  # 2 s at 240 Hz: the whole run
    with np.load(run / "poses.npz") as poses:  # the write was let finish
        assert poses["tick"][-1] == 480
    assert sorted(p.name for p in run.iterdir()) == ["poses.npz", "result.json", "trace.jsonl"]
    assert f"robokit: interrupted ({sig.name}); the result was kept" in err
    assert "internal error" not in err and "Traceback" not in err


def test_a_second_signal_abandons_the_pose_log_and_keeps_the_result(
        scene: Path, monkeypatch: pytest.MonkeyPatch, capsys: Any) -> None:
    """Two signals during the pose log (the user insists): the log is abandoned at once, the result stays, the
    temporary file is gone, and the record failure is named."""
    original = Recorder.poses

    def poses_twice_signalled(self: Recorder) -> dict[str, np.ndarray]:
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGINT)
        return original(self)

    monkeypatch.setattr(Recorder, "poses", poses_twice_signalled)
    assert main(["run", str(scene)]) == 130
    out = capsys.readouterr().out
    run = only_run(scene.parent)
    assert json.loads((run / "result.json").read_text())["outcome"] == "succeeded"
    assert sorted(p.name for p in run.iterdir()) == ["result.json", "trace.jsonl"]
    assert "warning: run record: the pose log was abandoned (SIGINT); the result is kept" in out


@pytest.mark.skipif(shutil.which("prlimit") is None, reason="needs util-linux's prlimit")
def test_a_file_size_limit_on_the_record_is_a_warning_naming_the_file_and_exit_6(scene: Path) -> None:
    """``prlimit --fsize`` below the pose log's size (but above result.json's): EFBIG on the record's writes."""
    limit = 6000
    proc = subprocess.run(["prlimit", f"--fsize={limit}", sys.executable, "-m", "robokit.cli", "run",
                           str(scene)], cwd=scene.parent, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 6, proc.stderr
    run = only_run(scene.parent)
    result = json.loads((run / "result.json").read_text())
    assert result["outcome"] == "succeeded"
    assert (run / "trace.jsonl").stat().st_size <= limit
    assert not (run / "poses.npz").exists()
    assert not list(run.glob("*.tmp*"))
    pose_line = f"warning: run record: writing {Path('results') / run.name / 'poses.npz'} failed: File too large; " \
                "the pose log was not kept"
    assert pose_line in proc.stdout
    assert "internal error" not in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.parametrize("outcome, stored, failures, signal_name, expected", [
    ("succeeded", True, [], None, 0),
    ("succeeded", True, ["run record: writing x failed"], None, 6),
    ("failed", True, ["run record: writing x failed"], None, 1),
    ("error", True, ["run record: writing x failed"], None, 3),
    ("succeeded", False, ["run record: writing x failed"], None, 4),
    ("succeeded", True, ["run record: writing x failed"], "SIGTERM", 143),
    ("succeeded", False, [], "SIGINT", 130),
])
def test_exit_codes_follow_the_documented_table(outcome: str, stored: bool, failures: list[str],
                                                signal_name: str | None, expected: int) -> None:
    """The cli docstring's table: a signal first (130 / 143), then 4 (kept nowhere), then the outcome's code, and
    6 only in place of a success."""
    from robokit.components import Delivery
    from robokit.core.result import RunResult
    from robokit.runner import RunOutput

    result = RunResult(run_id="r", robokit_version="0", config="c", behaviour=None, seed=0, outcome=outcome,
                       reason="", ticks=1, sim_time=0.1, wall_time=0.1, started_at="")
    out = RunOutput(result, {}, [("local", Delivery(stored, None, ""))], interrupted=signal_name is not None,
                    signal=signal_name, record_failures=failures)
    assert out.exit_code == expected


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_after_the_command_ended_still_exits_with_its_code(sig: signal.Signals, code: int) -> None:
    """The last moment: the command is done (exit code 0 decided) and Python is shutting down, which puts the
    default handlers back; a signal then still ends the process with 130 / 143 and one line, not a silent kill."""
    script = ("import os, signal, sys\n"
              "from robokit.process.interrupts import StopGuard\n"
              "guard = StopGuard.for_process()\n"
              "code = guard.closing(0)\n"
              "for s in (signal.SIGINT, signal.SIGTERM):\n"
              "    signal.signal(s, signal.SIG_DFL)  # what the interpreter's shutdown does\n"
              f"os.kill(os.getpid(), signal.{sig.name})\n"
              "sys.exit(code)\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert proc.returncode == code
    assert proc.stderr == f"robokit: interrupted ({sig.name}) while exiting; exit code {code}\n"
