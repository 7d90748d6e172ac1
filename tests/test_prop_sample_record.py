"""A run record against the run it records: the header's pose rate against the samples' spacing, the pose log's
last sample against the world at the end, and the replay's base frames against the world's own link-frame poses."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robokit.record.format import RunRecord
from robokit.record.recorder import Recorder
from robokit.record.replay import replay_of
from robokit.testing import PLANE, make_sim

SCENE = {
    "world": {"max_time": 5.0},
    "bodies": {"plane": PLANE,
               "box": {"shape": "box", "size": [0.1, 0.2, 0.1], "mass": 1.0, "position": [0.3, 0.1, 0.4],
                       "rpy_deg": [20, 10, 35]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06], "rpy_deg": [0, 0, 57]}},
    "actuators": {"drive": {"type": "diff_drive", "robot": "robot"}},
}


def recorded(tmp_path: Path, pose_hz: float, ticks: int) -> tuple[RunRecord, dict, int]:
    """Record ``ticks`` ticks of the scene (the robot driving a curve); the record, the world's final link-frame
    and centre-of-mass poses by body, and the final tick."""
    from robokit.msgs.mobile import Twist

    with make_sim(SCENE, seed=1) as sim:
        recorder = Recorder(sim, tmp_path / "run", pose_hz=pose_hz)
        sim.add_monitor(recorder)
        sim.components["drive"].command(Twist(0.3, 1.1))
        sim.step(ticks)
        final = {name: (sim.world.pose(name), sim.world.com_pose(name)) for name in ("box", "robot")}
        tick = sim.world.tick
        assert recorder.close() == []
    return RunRecord(tmp_path / "run"), final, tick


@pytest.mark.parametrize("pose_hz, ticks", [(30.0, 97), (7.0, 130), (45.0, 61), (100.0, 50)])
def test_the_header_rate_is_the_logged_rate_and_the_last_sample_is_the_end(tmp_path: Path, pose_hz: float,
                                                                           ticks: int) -> None:
    rec, final, end_tick = recorded(tmp_path, pose_hz, ticks)
    t, logged_ticks = rec.poses["t"], rec.poses["tick"]
    step = float(rec.header["time_step"])
    spacing = np.diff(logged_ticks[:-1])  # every sample but the last (the final state, off the grid)
    assert len(set(spacing.tolist())) == 1
    assert math.isclose(float(rec.header["pose_hz"]), 1.0 / (spacing[0] * step), rel_tol=1e-9)
    assert np.allclose(t, logged_ticks * step)
    # the last sample is the world as the run ended
    assert int(logged_ticks[-1]) == end_tick
    for name, (_, (com_pos, com_orn)) in final.items():
        row = rec.poses[f"base/{name}"][-1]
        assert np.allclose(row[:3], com_pos, atol=1e-6) and np.allclose(row[3:], com_orn, atol=1e-6), name


def test_replay_base_frames_are_the_world_link_frames(tmp_path: Path) -> None:
    rec, final, _ = recorded(tmp_path, 30.0, 80)
    replay = replay_of(rec)
    for name, ((pos, orn), _) in final.items():
        k = next(i for i, link in enumerate(replay.links) if link.body == name and link.index == -1)
        got = replay.poses[-1, k]
        assert np.allclose(got[:3], pos, atol=1e-5), (name, got[:3], pos)
        same = abs(float(np.dot(got[3:], orn)))  # q and -q are one rotation
        assert same > 1 - 1e-6, (name, got[3:], orn)
