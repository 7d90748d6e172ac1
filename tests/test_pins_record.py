"""The run record read back, and the pictures judged by what they draw (not by file size): a machine's stays from
its transitions, the state at a transition's instant, the newest run as 'last', heights plotted as z, the driven
path in x/y, state bars as long as the stays."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.record.format import RECORD_SCHEMA, RunRecord, find_run
from robokit.record.plots import _pyplot, plot_heights, plot_map, plot_states

DROP = """
[world]
max_time = 1.0
[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]
[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
mass = 1.0
position = [0, 0, 0.5]
"""

PARKED = """
[world]
max_time = 0.5
[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]
[robots.robot]
urdf = "robots/diffbot.urdf"
position = [1.0, -0.5, 0.06]
[actuators.drive]
type = "diff_drive"
"""


def synthetic(folder: Path, transitions: list[tuple[float, str, str]], sim_time: float) -> RunRecord:
    folder.mkdir(parents=True)
    header = {"kind": "header", "schema": RECORD_SCHEMA, "config": {}, "bodies": {}, "seed": 0,
              "machines": [{"name": "m", "initial": "A"}]}
    events = [{"kind": "transition", "t": t, "tick": round(t * 240), "machine": "m", "source_state": s,
               "dest_state": d, "trigger": "go"} for t, s, d in transitions]
    (folder / "trace.jsonl").write_text("\n".join(json.dumps(r) for r in [header, *events]) + "\n")
    (folder / "result.json").write_text(json.dumps({"run_id": folder.name, "sim_time": sim_time,
                                                    "outcome": "succeeded"}))
    return RunRecord(folder)


def test_spans_follow_the_transitions_and_a_state_begins_at_its_transition(tmp_path: Path) -> None:
    rec = synthetic(tmp_path / "r1", [(1.0, "A", "B"), (2.5, "B", "C")], 4.0)
    spans = rec.spans()
    assert [(s.state, s.start, s.end) for s in spans["m"]] == [("A", 0.0, 1.0), ("B", 1.0, 2.5), ("C", 2.5, 4.0)]
    assert rec.state_at(spans, 0.99) == {"m": "A"}
    assert rec.state_at(spans, 1.0) == {"m": "B"}
    assert rec.state_at(spans, 2.5) == {"m": "C"}


def test_state_bars_are_as_long_as_the_stays(tmp_path: Path) -> None:
    rec = synthetic(tmp_path / "r2", [(1.0, "A", "B"), (2.5, "B", "C")], 4.0)
    plt = _pyplot()
    fig = plot_states(rec, plt)
    bars = sorted((round(p.get_x(), 6), round(p.get_width(), 6)) for p in fig.axes[0].patches
                  if p.get_height() > 0 and p.get_width() > 0 and p.get_y() < 1)
    plt.close(fig)
    assert bars == [(0.0, 1.0), (1.0, 1.5), (2.5, 1.5)]


def test_last_is_the_newest_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    old = synthetic(tmp_path / "results" / "zzz-old", [], 1.0)
    new = synthetic(tmp_path / "results" / "aaa-new", [], 1.0)
    os.utime(old.folder / "trace.jsonl", (1_700_000_000, 1_700_000_000))
    os.utime(new.folder / "trace.jsonl", (1_800_000_000, 1_800_000_000))
    assert find_run("last").run_id == "aaa-new"


def recorded(tmp_path: Path, text: str, monkeypatch: pytest.MonkeyPatch) -> RunRecord:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text(text)
    assert main(["run", "scene.toml", "--quiet"]) == 0
    return find_run("last")


def test_the_height_plot_draws_each_bodys_z_over_time(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rec = recorded(tmp_path, DROP, monkeypatch)
    plt = _pyplot()
    fig = plot_heights(rec, plt)
    [line] = fig.axes[0].lines
    t, z = line.get_xdata(), line.get_ydata()
    plt.close(fig)
    assert np.allclose(t, rec.poses["t"]) and np.allclose(z, rec.poses["base/box"][:, 2])
    assert z[0] == pytest.approx(0.5, abs=1e-3) and z[-1] == pytest.approx(0.05, abs=0.01)  # fell onto the floor
    ticks = rec.poses["tick"]
    assert ticks.tolist() == list(range(0, 241, 8))  # 30 Hz at 240 Hz: every 8th tick, the final tick (240) too
    assert np.allclose(rec.poses["t"], ticks / 240.0)


def test_the_map_draws_the_driven_path_in_x_and_y(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rec = recorded(tmp_path, PARKED, monkeypatch)
    plt = _pyplot()
    fig = plot_map(rec, plt)
    path = next(ln for ln in fig.axes[0].lines if ln.get_label() == "driven path")
    x, y = np.asarray(path.get_xdata()), np.asarray(path.get_ydata())
    plt.close(fig)
    assert np.allclose(x, 1.0, atol=0.05) and np.allclose(y, -0.5, atol=0.05)  # parked at (1.0, -0.5)
