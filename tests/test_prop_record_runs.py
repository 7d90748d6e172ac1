"""Finding runs and their saved frames, over generated results folders.

``robokit results``, ``view``, ``replay`` and ``export`` take a run as an id, a unique prefix of one, ``last`` or a
folder (``find_run``); runs are listed oldest first by when their record was written (``run_folders``); saved camera
frames (``frames/<camera>_<tick>_rgb.png``) are read back in time order (``camera_frames``); the table's figures are
the first scalar ones of the result (``headline``). Here folders, times, ids, cameras and ticks are generated, and
each answer is worked out plainly: which names start with the prefix, the newest modification time, the tick times
the time step, the result's numbers in order.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.errors import UserError
from robokit.record.format import RunRecord, find_run, run_folders
from robokit.record.layout import FRAMES_DIR, RESULT_FILE, TRACE_FILE
from robokit.record.replay import camera_frames
from robokit.record.results import headline

PROPS = settings(max_examples=40, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
HEADER = {"kind": "header", "schema": "robokit.record/1", "machines": []}

runs = st.lists(st.tuples(st.text("0123ab", min_size=3, max_size=6), st.integers(0, 5),
                          st.sampled_from(["trace", "result", "both", "neither"])),
                min_size=0, max_size=6, unique_by=lambda r: r[0])


@PROPS
@given(runs, st.text("0123ab", min_size=1, max_size=4))
def test_a_run_is_found_by_id_prefix_last_or_folder(tmp_path_factory: pytest.TempPathFactory,
                                                     folders: list[tuple[str, int, str]], prefix: str) -> None:
    root = tmp_path_factory.mktemp("results")
    for name, age, files in folders:
        d = root / name
        d.mkdir()
        written = []
        if files in ("trace", "both"):
            (d / TRACE_FILE).write_text(json.dumps(HEADER) + "\n", encoding="utf-8")
            written.append(d / TRACE_FILE)
        if files in ("result", "both"):
            (d / RESULT_FILE).write_text("{}", encoding="utf-8")
            written.append(d / RESULT_FILE)
        for f in written:  # the trace decides the order when there is one; age 0 is the newest
            os.utime(f, (1_000_000 - age * 100, 1_000_000 - age * 100))
        if files == "both":
            os.utime(d / RESULT_FILE, (1, 1))
    runs_ = [(n, a) for n, a, f in folders if f != "neither"]
    oldest_first = [n for n, _ in sorted(runs_, key=lambda r: (-r[1], r[0]))]
    assert [p.name for p in run_folders(root)] == oldest_first

    matches = [n for n, _ in runs_ if n.startswith(prefix)]
    if len(matches) == 1:
        assert find_run(prefix, root).folder == root / matches[0]
    else:
        with pytest.raises(UserError) as err:
            find_run(prefix, root)
        assert (f"no run {prefix!r}" if not matches else f"matches {len(matches)} runs") in str(err.value)
    if runs_:
        assert find_run("last", root).folder == root / oldest_first[-1]
        name = oldest_first[0]
        assert find_run(str(root / name), root / "elsewhere").folder == root / name  # a folder, wherever it is
    else:
        with pytest.raises(UserError, match="no runs in"):
            find_run("last", root)


@PROPS
@given(st.lists(st.tuples(st.sampled_from(["cam", "wrist_cam", "cam_2", "top"]), st.integers(0, 5000)),
                max_size=8, unique=True),
       st.sampled_from([1 / 240, 1 / 100, 0.01]))
def test_saved_frames_come_back_in_time_order_at_their_ticks(tmp_path_factory: pytest.TempPathFactory,
                                                              frames: list[tuple[str, int]], step: float) -> None:
    folder = tmp_path_factory.mktemp("run")
    (folder / TRACE_FILE).write_text(json.dumps({**HEADER, "time_step": step}) + "\n", encoding="utf-8")
    (folder / FRAMES_DIR).mkdir()
    for camera, tick in frames:
        (folder / FRAMES_DIR / f"{camera}_{tick}_rgb.png").write_bytes(b"png")
        (folder / FRAMES_DIR / f"{camera}_{tick}_depth.png").write_bytes(b"not a colour frame")
    got = camera_frames(RunRecord(folder))
    assert [(c, t, p.name) for c, t, p in got] == sorted(
        ((c, k * step, f"{c}_{k}_rgb.png") for c, k in frames), key=lambda x: (x[1], x[2]))


@given(st.dictionaries(st.text("abcxyz", min_size=1, max_size=3),
                       st.one_of(st.integers(-99, 99), st.floats(-1e3, 1e3, allow_nan=False), st.booleans(),
                                 st.none(), st.text(max_size=2), st.lists(st.integers(), max_size=1)), max_size=7),
       st.integers(1, 5))
@settings(max_examples=100, deadline=None, derandomize=True)
def test_the_headline_is_the_results_first_numbers(result: dict[str, Any], limit: int) -> None:
    numbers = [(k, v) for k, v in result.items() if isinstance(v, int | float) and not isinstance(v, bool)][:limit]
    want = " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in numbers)
    assert headline(result, limit) == want


def test_a_folder_without_a_record_is_not_a_run(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="no run 'empty'"):
        find_run("empty", tmp_path)
