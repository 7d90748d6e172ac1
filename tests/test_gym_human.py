"""``render_mode="human"``: the episode runs in PyBullet's GUI window (on a virtual display here), paced to
wall-clock time, with the same physics as headless: the same seed and actions give the same observations."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import robokit.gym

pytestmark = pytest.mark.slow

STEPS = 10
ACTION = [0.6, -0.3, 0.2]

HUMAN_RUN = f"""
import json
import numpy as np
import pybullet
import robokit.gym

env = robokit.gym.make_shipped("Reach", render_mode="human")
scheduler = env.unwrapped.sim.scheduler
wall = [0.0]
slept = []
scheduler.wall_clock = lambda: wall[0]              # a clock that only moves when pacing sleeps

def sleep(seconds):
    slept.append(seconds)
    wall[0] += seconds

scheduler.sleep = sleep
obs, _ = env.reset(seed=3)
observations = [obs.tolist()]
for _ in range({STEPS}):
    obs, *_ = env.step(np.array({ACTION}, dtype=np.float32))
    observations.append(obs.tolist())
world = env.unwrapped.world
method = pybullet.getConnectionInfo(physicsClientId=world.cid)["connectionMethod"]
print(json.dumps({{"observations": observations, "gui": method == pybullet.GUI, "slept": sum(slept),
                  "episode_time": env.unwrapped.episode_ticks * world.time_step, "render": env.render()}}))
env.close()
"""


def test_human_mode_opens_the_window_paces_to_sim_time_and_keeps_the_physics(virtual_display) -> None:
    proc = subprocess.run([sys.executable, "-c", HUMAN_RUN], capture_output=True, text=True, timeout=300,
                          env=virtual_display)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (line,) = [text for text in proc.stdout.splitlines() if text.startswith("{")]  # pybullet prints its own lines
    human = json.loads(line)
    assert human["gui"] is True
    assert human["render"] is None  # Gymnasium's human mode: the window is the rendering
    assert human["episode_time"] == pytest.approx(STEPS * 0.04)
    assert human["slept"] == pytest.approx(human["episode_time"], abs=1e-9)  # wall time caught up with sim time

    env = robokit.gym.make_shipped("Reach")  # headless, in this process
    try:
        obs, _ = env.reset(seed=3)
        headless = [obs.tolist()]
        for _ in range(STEPS):
            obs, *_ = env.step(np.array(ACTION, dtype=np.float32))
            headless.append(obs.tolist())
    finally:
        env.close()
    assert human["observations"] == headless


def test_unknown_render_modes_are_refused() -> None:
    with pytest.raises(ValueError, match="render_mode must be one of"):
        robokit.gym.make_shipped("Reach", render_mode="window")
