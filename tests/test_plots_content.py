"""What the plots show, judged on the drawn figure: ``heights`` names every movable body of the drop test (a
``count = 20`` group as one entry), ``states`` marks the states a machine left in the tick it entered them, and no
bar label is cut off or spills out of its bar."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib
import pytest
import tomllib

from robokit.cli import main
from robokit.record.format import RunRecord, find_run
from robokit.record.plots import plot_heights, plot_states

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 - after the backend is chosen

ROOT = Path(__file__).resolve().parents[1]


def _record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, config: str, max_time: float) -> RunRecord:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(ROOT / "configs" / config), "--quiet", "--max-time", str(max_time)]) in (0, 1)
    return find_run("last")


@pytest.fixture
def figures() -> Iterator[list[Any]]:
    made: list[Any] = []
    yield made
    for fig in made:
        plt.close(fig)


def test_heights_names_every_movable_body_and_groups_counted_copies(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, figures: list[Any]) -> None:
    raw = tomllib.loads((ROOT / "configs" / "drop_test.toml").read_text(encoding="utf-8"))
    movable = {name: spec.get("count", 1) for name, spec in raw["bodies"].items() if spec.get("mass", 1.0) > 0
               and spec.get("urdf") != "plane.urdf"}
    assert sum(movable.values()) == 33 and max(movable.values()) == 20
    rec = _record(tmp_path, monkeypatch, "drop_test.toml", 0.5)
    fig = plot_heights(rec, plt)
    figures.append(fig)
    ax = fig.axes[0]
    legend = ax.get_legend()
    assert legend is not None
    shown = [t.get_text() for t in legend.get_texts()]
    expected = [name if n == 1 else f"{name}_0 .. {name}_{n - 1} ({n})" for name, n in movable.items()]
    assert sorted(shown) == sorted(expected)
    lines = ax.get_lines()
    assert len(lines) == 33
    # the copies of a counted body share one colour; every named body has a colour of its own
    colours = {line.get_label(): line.get_color() for line in lines if not line.get_label().startswith("_")}
    assert len(set(map(str, colours.values()))) == len(expected)
    group = [line for line in lines if line.get_label().startswith("_") or "(20)" in line.get_label()]
    assert len(group) == 20 and len({str(line.get_color()) for line in group}) == 1


def _pixels(ax: Any, x0: float, x1: float) -> tuple[float, float]:
    left, right = ax.transData.transform([(x0, 0), (x1, 0)])[:, 0]
    return left, right


def test_states_marks_zero_second_states_and_keeps_labels_inside_their_bars(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, figures: list[Any]) -> None:
    rec = _record(tmp_path, monkeypatch, "sort_robot.toml", 2.5)  # the first pick and the look after it
    # the stays, read from the trace file itself: (machine, state, start, end)
    events = [json.loads(line) for line in (rec.folder / "trace.jsonl").read_text().splitlines()[1:]]
    moves = [e for e in events if e.get("kind") == "transition"]
    zero = {(e["machine"], e["dest_state"], e["t"]) for e, after in zip(moves, moves[1:], strict=False)
            if after["machine"] == e["machine"] and after["t"] == e["t"]}
    zero = {z for z in zero if any(a["machine"] == z[0] and a["t"] == z[2] and a["source_state"] == z[1]
                                   for a in moves)}
    assert any(state == "LOOK" for _, state, _ in zero), zero  # the sort decides in the tick it looks
    fig = plot_states(rec, plt)
    figures.append(fig)
    ax = fig.axes[0]
    rows = [t.get_text() for t in ax.get_yticklabels()]
    legend = dict(zip((t.get_text() for t in ax.get_legend().get_texts()),
                      (h.get_facecolor() for h in ax.get_legend().legend_handles), strict=True))
    markers = [(line.get_xdata()[0], line.get_ydata()[0], line.get_color()) for line in ax.get_lines()
               if line.get_marker() == "v"]
    for machine, state, t in zero:
        row = rows.index(machine)
        assert any(abs(x - t) < 1e-9 and abs(y - row) < 0.5 and matplotlib.colors.same_color(c, legend[state])
                   for x, y, c in markers), (machine, state, t)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    inside = ax.get_window_extent(renderer)
    bars = [(p.get_x(), p.get_x() + p.get_width()) for p in ax.patches]
    assert ax.texts, "no state is labelled at all"
    for text in ax.texts:
        box = text.get_window_extent(renderer)
        assert inside.x0 <= box.x0 and box.x1 <= inside.x1, f"{text.get_text()} is cut off by the axes"
        x = text.get_position()[0]
        left, right = _pixels(ax, *next(b for b in bars if b[0] <= x <= b[1]))
        assert left <= box.x0 and box.x1 <= right, f"{text.get_text()} spills out of its bar"
