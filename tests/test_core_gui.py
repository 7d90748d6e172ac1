"""GUI mode, for real, on a virtual display (Xvfb). `.ci/run` installs xvfb; without it there is no display."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow  # a whole GUI run under Xvfb: the slow tier (the default tier keeps its two-minute budget)
def test_gui_run_under_xvfb(tmp_path: Path, virtual_display: dict[str, str]) -> None:
    cmd = [sys.executable, "-m", "robokit.cli", "run",
           str(ROOT / "configs" / "drive_teleop.toml"), "--gui", "--max-time", "0.25", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path, env=virtual_display)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    # With a GUI the keyboard sensor reads real keys (none pressed), so the open-ended teleop runs to max_time.
    assert result["outcome"] == "succeeded" and "max_time" in result["reason"]
    assert abs(result["result"]["final_pose"][0]) < 0.05  # no key pressed: the robot stays put
    assert result["ticks"] == 60  # 0.25 s at 240 Hz


class FakeClock:
    """A wall clock that only moves when told: each tick of work costs ``work`` seconds, sleeping moves it on."""

    def __init__(self, work: float) -> None:
        self.now, self.work, self.slept = 100.0, work, []

    def __call__(self) -> float:
        self.now += self.work
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds


@pytest.mark.parametrize("work, sleeps", [(0.001, 240), (0.010, 0)])
def test_pacing_holds_sim_time_to_the_wall_clock(work: float, sleeps: int) -> None:
    """Faster than real time (1 ms of work per 4.2 ms tick): pace() sleeps after every tick so that sim time never
    runs ahead of the clock. Slower (10 ms a tick): it never sleeps. Counted with a clock that moves on command."""
    from robokit.testing import PLANE, make_sim

    with make_sim({"bodies": {"plane": PLANE}}) as sim:
        clock = FakeClock(work)
        sim.scheduler.wall_clock, sim.scheduler.sleep = clock, clock.sleep
        sim.scheduler.start_pacing()
        start = clock.now
        for _ in range(240):
            sim.scheduler.tick()
            sim.scheduler.pace()
            assert sim.world.time <= clock.now - start + 1e-9  # never ahead of the wall clock
        assert len(clock.slept) == sleeps
        if sleeps:
            assert clock.now - start == pytest.approx(1.0, abs=0.002)  # one sim second took one wall second
