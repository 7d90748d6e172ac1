"""The pose log's samples against a plain PyBullet world stepped by hand.

docs/records.md: pose samples come ``pose_hz`` times a sim second, rounded to a whole number of physics ticks (the
header's ``pose_hz`` is the rate actually used), taken at the **start** of a tick, so sample ``k`` is the scene at
``t[k] = tick[k] x time_step`` -- after ``tick[k]`` physics steps -- plus a last sample of the final state. A box
falls freely for half a second; the same box is dropped in a DIRECT client of the test's own, stepped one tick at a
time, and every sample's position and orientation is compared with the hand-stepped box after that many steps (a
sample taken one step late is up to 2 cm off).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pybullet as pb
import pytest

from robokit.cli import main
from robokit.record.format import find_run

SCENE = """
[world]
max_time = 0.5

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0, 0, 5]
rpy_deg = [0, 0, 30]
"""


def by_hand(steps: int) -> list[tuple[list[float], list[float]]]:
    """The box's pose after 0, 1, ... ``steps`` physics steps of 1/240 s, in a world of the test's own."""
    client = pb.connect(pb.DIRECT)
    try:
        pb.setGravity(0, 0, -9.81, physicsClientId=client)
        pb.setTimeStep(1 / 240, physicsClientId=client)
        shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.05] * 3, physicsClientId=client)
        box = pb.createMultiBody(1.0, shape, basePosition=[0, 0, 5],
                                 baseOrientation=pb.getQuaternionFromEuler([0, 0, np.radians(30)]),
                                 physicsClientId=client)
        out = []
        for _ in range(steps + 1):
            pos, orn = pb.getBasePositionAndOrientation(box, physicsClientId=client)
            out.append((list(pos), list(orn)))
            pb.stepSimulation(physicsClientId=client)
        return out
    finally:
        pb.disconnect(client)


@pytest.mark.parametrize("hz", [45, pytest.param(240, marks=pytest.mark.slow), pytest.param(7, marks=pytest.mark.slow),
                                pytest.param(1000, marks=pytest.mark.slow)])
def test_every_sample_is_the_scene_at_the_start_of_its_tick(tmp_path: Path, hz: int) -> None:
    (tmp_path / "fall.toml").write_text(SCENE)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["run", "fall.toml", "--quiet", "--pose-hz", str(hz)]) == 0
    finally:
        os.chdir(cwd)
    record = find_run("last", tmp_path / "results").folder
    poses = np.load(record / "poses.npz")
    header = json.loads((record / "trace.jsonl").read_text().splitlines()[0])
    result = json.loads((record / "result.json").read_text())
    period = max(1, round(240 / hz))
    ticks = list(range(0, result["ticks"] + 1, period))
    if ticks[-1] != result["ticks"]:
        ticks.append(result["ticks"])  # the final state
    assert [int(k) for k in poses["tick"]] == ticks and result["ticks"] == 120
    assert list(poses["t"]) == [k * (1 / 240) for k in ticks]
    assert header["pose_hz"] == pytest.approx(240 / period) and header["time_step"] == pytest.approx(1 / 240)
    assert poses["base/box"].dtype == np.float32 and poses["base/box"].shape == (len(ticks), 7)
    hand = by_hand(result["ticks"])
    for k, row in zip(ticks, poses["base/box"], strict=True):
        pos, orn = hand[k]
        assert row[:3] == pytest.approx(pos, abs=2e-6), k
        assert abs(float(np.dot(row[3:], orn))) == pytest.approx(1.0, abs=1e-6), k
    assert hand[120][0][2] < 5 - 1.2  # it fell: at ~4.9 m/s a sample one step late is 2 cm off
