"""Which pose sample each video frame and each still shows, over generated pose logs.

docs/records.md: video frames count from 0 at the pose log's rate (``--fps`` otherwise), frame ``k`` is the scene at
sim time ``k / fps`` -- the pose sample at or just before it -- up to the last sample; ``--frame N`` is frame N
(``-1`` the last), ``--time S`` the frame at S seconds, ``--time end`` the last; anything outside is one line naming
the range. Sample times are generated (regular at a whole number of ticks, and a last sample of the final state
at any tick) and each answer is found by walking the samples.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.errors import UserError
from robokit.record.cli import _still_frame
from robokit.record.format import RunRecord
from robokit.record.layout import POSES_FILE, TRACE_FILE
from robokit.record.video import frame_indices

PROPS = settings(max_examples=60, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
STEP = 1 / 240


@st.composite
def logs(draw: st.DrawFn) -> tuple[np.ndarray, float]:
    """Sample times: every ``period`` ticks from 0, then the final tick (if not a sample already); the log's rate."""
    period = draw(st.sampled_from([1, 4, 8, 24]))
    last = draw(st.integers(0, 400))
    ticks = list(range(0, last + 1, period))
    if ticks[-1] != last:
        ticks.append(last)
    return np.asarray(ticks, float) * STEP, 240 / period


def shown(t: np.ndarray, at: float) -> int:
    """The last sample at or before ``at`` (the first when none is), found by walking."""
    best = 0
    for i, ti in enumerate(t):
        if ti <= at + 1e-9:
            best = i
    return best


@PROPS
@given(logs(), st.sampled_from([None, 10.0, 25.0, 30.0, 60.0]))
def test_each_video_frame_shows_the_sample_at_or_just_before_its_time(log: tuple[np.ndarray, float],
                                                                     fps: float | None) -> None:
    t, hz = log
    rate = fps or hz
    got = frame_indices(t, rate)
    count = 1
    while count / rate <= t[-1] + 1e-6:  # the next frame's time is within the log
        count += 1
    assert len(got) == count  # frames from t = 0 up to the last sample, none past it
    assert got == [shown(t, k / rate) for k in range(count)]
    assert frame_indices(np.array([]), rate) == []


@PROPS
@given(logs(), st.one_of(st.integers(-500, 500).map(lambda n: ("frame", n)),
                         st.floats(-1, 3, allow_nan=False).map(lambda s: ("time", s)),
                         st.sampled_from([("time", "end"), ("time", " End "), ("time", "soon")])),
       st.sampled_from([None, 10.0]))
def test_a_still_is_the_frame_asked_for_or_one_line_naming_the_range(
        tmp_path_factory: pytest.TempPathFactory, log: tuple[np.ndarray, float], ask: tuple[str, object],
        fps: float | None) -> None:
    t, hz = log
    folder = tmp_path_factory.mktemp("run")
    (folder / TRACE_FILE).write_text(json.dumps({"kind": "header", "schema": "robokit.record/1", "pose_hz": hz,
                                                 "time_step": STEP, "machines": []}) + "\n", encoding="utf-8")
    np.savez(folder / POSES_FILE, t=t, tick=np.round(t / STEP).astype(np.int64))
    rate = fps or hz
    frames = len(frame_indices(t, rate))
    kind, value = ask
    args = argparse.Namespace(fps=fps, frame=value if kind == "frame" else None, time=value if kind == "time" else None)
    if kind == "frame":
        k = value + frames if value < 0 else value  # type: ignore[operator]
        want = k if 0 <= k < frames else None
    elif str(value).strip().lower() == "end":
        want = frames - 1
    elif isinstance(value, float) and 0 <= value <= (frames - 1) / rate + 1e-9:
        want = math.floor(value * rate + 1e-6)
    else:
        want = None
    if want is None:
        with pytest.raises(UserError) as err:
            _still_frame(args, RunRecord(folder))
        text = str(err.value)
        assert "\n" not in text and text.startswith(f"--{kind}")
        if value != "soon":
            assert (f"frames 0 to {frames - 1}" if kind == "frame" else f"lasts 0 to {(frames - 1) / rate:.3f} s") \
                in text
    else:
        assert _still_frame(args, RunRecord(folder)) == want
        assert 0 <= want < frames
