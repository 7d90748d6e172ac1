"""GUI mode, for real, on a virtual display (Xvfb). `.ci/run` installs xvfb; without it there is no display."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
XVFB_RUN = shutil.which("xvfb-run")


@pytest.mark.skipif(XVFB_RUN is None, reason="no virtual display: install xvfb (apt-get install xvfb)")
def test_gui_run_under_xvfb(tmp_path: Path) -> None:
    cmd = [XVFB_RUN or "", "-a", "-s", "-screen 0 640x480x24", sys.executable, "-m", "robokit.cli", "run",
           str(ROOT / "configs" / "drive_teleop.toml"), "--gui", "--max-time", "0.25", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    # With a GUI the keyboard sensor reads real keys (none pressed), so the open-ended teleop runs to max_time.
    assert result["outcome"] == "succeeded" and "max_time" in result["reason"]
    assert abs(result["result"]["final_pose"][0]) < 0.05  # no key pressed: the robot stays put
    assert result["wall_time"] >= 0.25  # paced to real time
