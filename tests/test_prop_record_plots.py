"""``robokit plot``'s pictures read back from their matplotlib figures and compared with the record, over generated
records.

Records are generated (free bodies, bodies with ``mass = 0``, a ground plane, ``count = N`` copies, driven arms with
joints, machines with stays long and instant), and every line and bar is compared with the arrays and transition
records it was drawn from: the heights plot draws every free body's z over t (copies sharing one grey colour and one
legend entry, static bodies and the plane left out); the joints plot one panel per driven body, one line per joint
in the header's order; the state timeline one bar per stay, from its start to its end, in its machine's row (a stay
too short to see as a bar a marker at its start).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.record.format import RunRecord
from robokit.record.layout import POSES_FILE, TRACE_FILE
from robokit.record.plots import plot_heights, plot_joints, plot_states

plt = pytest.importorskip("matplotlib.pyplot")
PROPS = settings(max_examples=10, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@st.composite
def records(draw: st.DrawFn) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    n = draw(st.integers(2, 12))
    t = np.arange(n) / 30
    rng = np.random.default_rng(draw(st.integers(0, 99)))
    config: dict[str, Any] = {"bodies": {}, "actuators": {}, "behaviour": {"type": draw(st.sampled_from(
        ["drop_test", "sort"]))}}
    bodies: dict[str, Any] = {}
    poses = {"t": t, "tick": np.arange(n) * 8}
    for name in draw(st.lists(st.sampled_from(["ball", "crate", "plane", "shelf", "cube"]), unique=True,
                              min_size=1, max_size=4)):
        section = {"plane": {"urdf": "plane.urdf"}, "shelf": {"shape": "box", "mass": 0}}.get(
            name, {"shape": "box", "mass": draw(st.sampled_from([0.5, 2]))})
        config["bodies"][name] = section
        copies = [f"{name}_{k}" for k in range(draw(st.integers(2, 3)))] if name == "cube" else [name]
        for body in copies:
            bodies[body] = {"links": ["base"], "joints": []}
            poses[f"base/{body}"] = rng.normal(size=(n, 7)).astype(np.float32)
    arms = [] if config["behaviour"]["type"] == "drop_test" else draw(st.lists(st.sampled_from(["kuka", "panda"]),
                                                                               unique=True, max_size=2))
    for arm in arms:
        config.setdefault("robots", {})[arm] = {"urdf": f"{arm}.urdf"}
        joints = [f"{arm}_j{j}" for j in range(draw(st.integers(1, 3)))]
        bodies[arm] = {"links": ["base"], "joints": joints}
        poses[f"base/{arm}"] = rng.normal(size=(n, 7)).astype(np.float32)
        poses[f"joints/{arm}"] = rng.normal(size=(n, len(joints))).astype(np.float32)
        if draw(st.booleans()):
            config["actuators"][f"{arm}_drive"] = {"type": "joint_control", "body": arm}
    return {"config": config, "bodies": bodies}, poses


def write(folder: Any, header: dict[str, Any], poses: dict[str, np.ndarray], events: list[Any] = ()) -> RunRecord:
    head = {"kind": "header", "schema": "robokit.record/1", "machines": [], **header}
    (folder / TRACE_FILE).write_text("\n".join(json.dumps(x) for x in [head, *events]) + "\n", encoding="utf-8")
    np.savez(folder / POSES_FILE, **poses)  # type: ignore[arg-type]
    return RunRecord(folder)


@PROPS
@given(records())
def test_the_heights_plot_is_every_free_bodys_z_over_time(tmp_path_factory: pytest.TempPathFactory,
                                                         made: tuple[dict[str, Any], dict[str, np.ndarray]]) -> None:
    header, poses = made
    rec = write(tmp_path_factory.mktemp("run"), header, poses)
    config = header["config"]
    free = [b for b in header["bodies"] if b not in ("plane", "shelf") and b not in ("kuka", "panda")]
    fig = plot_heights(rec, plt)
    if not free or "robots" in config:  # a robot's scene: its arm's joints are drawn instead
        assert fig is None
        return
    try:
        [ax] = fig.axes
        lines = ax.get_lines()
        assert len(lines) == len(free)
        for line, body in zip(lines, free, strict=True):
            x, y = line.get_data()
            assert np.array_equal(x, poses["t"]) and np.array_equal(y, poses[f"base/{body}"][:, 2]), body
        cubes = [b for b in free if b.startswith("cube_")]
        grey = [line for line in lines if line.get_color() == "0.5"]
        assert len(grey) == (len(cubes) if len(cubes) > 1 else 0)  # copies of one section share one colour
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert labels == [f"cube_0 .. cube_{len(cubes) - 1} ({len(cubes)})" if b == "cube_0" else b
                          for b in free if not b.startswith("cube_") or b == "cube_0"]
        colours = [line.get_color() for line in lines if line.get_color() != "0.5"]
        assert len({str(c) for c in colours}) == len(colours)  # every other body a colour of its own
    finally:
        plt.close(fig)


@PROPS
@given(records())
def test_the_joints_plot_is_every_driven_joint_over_time(tmp_path_factory: pytest.TempPathFactory,
                                                        made: tuple[dict[str, Any], dict[str, np.ndarray]]) -> None:
    header, poses = made
    rec = write(tmp_path_factory.mktemp("run"), header, poses)
    driven = [a["body"] for a in header["config"]["actuators"].values()]
    fig = plot_joints(rec, plt)
    if not driven:
        assert fig is None
        return
    try:
        assert len(fig.axes) == len(driven)
        for ax, body in zip(fig.axes, driven, strict=True):
            joints = header["bodies"][body]["joints"]
            assert [line.get_label() for line in ax.get_lines()] == joints
            for j, line in enumerate(ax.get_lines()):
                x, y = line.get_data()
                assert np.array_equal(x, poses["t"]) and np.array_equal(y, poses[f"joints/{body}"][:, j])
            assert ax.get_ylabel().startswith(f"{body}:")
    finally:
        plt.close(fig)


@PROPS
@given(st.lists(st.tuples(st.sampled_from(["arm", "base"]), st.sampled_from(["A", "B", "C"]),
                          st.sampled_from([0.0, 0.001, 0.5, 2.0])), max_size=8), st.sampled_from([1.0, 4.0]))
def test_the_state_timeline_has_a_bar_or_a_marker_per_stay(tmp_path_factory: pytest.TempPathFactory,
                                                          moves: list[tuple[str, str, float]], end: float) -> None:
    from matplotlib.patches import Rectangle

    events, t, current = [], 0.0, {"arm": "A", "base": "B"}
    stays: dict[str, list[tuple[str, float, float]]] = {"arm": [], "base": []}
    since = {"arm": 0.0, "base": 0.0}
    for machine, dest, dt in moves:
        t = min(t + dt, end)
        events.append({"kind": "transition", "t": t, "machine": machine, "source_state": current[machine],
                       "dest_state": dest, "trigger": "go"})
        stays[machine].append((current[machine], since[machine], t))
        current[machine], since[machine] = dest, t
    for m in stays:
        stays[m].append((current[m], since[m], end))
    events.append({"kind": "end", "t": end})
    header = {"machines": [{"name": "arm", "initial": "A"}, {"name": "base", "initial": "B"}],
              "config": {}, "bodies": {}}
    rec = write(tmp_path_factory.mktemp("run"), header, {"t": np.array([0.0, end])}, events)
    fig = plot_states(rec, plt)
    try:
        ax = fig.axes[0]
        bars = sorted((round(p.get_x(), 9), round(p.get_width(), 9), round(p.get_y() + p.get_height() / 2))
                      for p in ax.patches if isinstance(p, Rectangle))
        markers = sorted((float(line.get_xdata()[0]), round(float(line.get_ydata()[0]) + 0.4))
                         for line in ax.get_lines())
        want_bars, want_markers = [], []
        for row, m in enumerate(["arm", "base"]):
            for _state, a, b in stays[m]:
                if b - a < end / 400:
                    want_markers.append((a, row))
                else:
                    want_bars.append((round(a, 9), round(b - a, 9), row))
        assert bars == sorted(want_bars)
        assert markers == sorted(want_markers)
        assert [t.get_text() for t in ax.get_yticklabels()] == ["arm", "base"]
        assert ax.get_xlim() == (0.0, end)
    finally:
        plt.close(fig)
