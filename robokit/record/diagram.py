"""State machine diagrams as inline SVG, drawn from a record header's machine structure (no JavaScript, offline).

Layout: states in columns by their shortest distance from the initial state (a layered drawing, like Mermaid's
``stateDiagram-v2`` left to right); arrows between boxes, labelled with their triggers; states the run visited
are filled, with the sim seconds spent in them.
"""

from __future__ import annotations

from collections import deque
from html import escape
from typing import Any

BOX_W, BOX_H, COL_GAP, ROW_GAP, BAND_GAP, PAD = 150, 40, 70, 26, 56, 20
MAX_COLS = 4
"""Columns per band: a longer chain of states wraps onto the next band, so the drawing stays about 850 px wide and
readable at its natural size in a 1280 px window (a 10-state pick_place was 2170 px, shrunk to half)."""
CHAR_W = 5.4
"""Width of one character of a 9 px label, roughly, in px: labels are kept inside the drawing's box."""


MANY = 3
"""A transition allowed from this many states or more (or from ``*``) is written under the drawing, not drawn as an
arrow from each (pick_place's ``retry`` and ``give_up`` drew 17 crossing arrows)."""


def _sources(machine: dict[str, Any], t: dict[str, Any]) -> list[str]:
    sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
    return list(machine["states"]) if "*" in sources else sources


def _edges(machine: dict[str, Any], *, everything: bool = False) -> list[tuple[str, str, str]]:
    """Arrows ``(source, dest, triggers)``; without ``everything``, not those of :func:`_any_state`."""
    out: dict[tuple[str, str], list[str]] = {}
    for t in machine["transitions"]:
        sources = _sources(machine, t)
        if everything or len(sources) < MANY:
            for s in sources:
                out.setdefault((s, t["dest"]), []).append(t["trigger"])
    return [(s, d, ", ".join(dict.fromkeys(triggers))) for (s, d), triggers in out.items()]


def _any_state(machine: dict[str, Any]) -> list[tuple[str, str, list[str]]]:
    """Transitions allowed from many states, as ``(trigger, dest, sources)``."""
    return [(t["trigger"], t["dest"], _sources(machine, t)) for t in machine["transitions"]
            if len(_sources(machine, t)) >= MANY]


def _layers(machine: dict[str, Any], edges: list[tuple[str, str, str]]) -> dict[str, int]:
    depth = {machine["initial"]: 0}
    queue = deque([machine["initial"]])
    while queue:
        s = queue.popleft()
        for a, b, _ in edges:
            if a == s and b not in depth:
                depth[b] = depth[s] + 1
                queue.append(b)
    last = max(depth.values(), default=0)
    for s in machine["states"]:
        depth.setdefault(s, last + 1)
    return depth


def _positions(machine: dict[str, Any], depth: dict[str, int]) -> dict[str, tuple[float, float]]:
    """Top-left corner of each state's box: columns by depth, wrapped into bands of :data:`MAX_COLS`."""
    columns: dict[int, list[str]] = {}
    for s in machine["states"]:
        columns.setdefault(depth[s], []).append(s)
    pos: dict[str, tuple[float, float]] = {}
    y = PAD + 24.0
    for band in range(max(columns) // MAX_COLS + 1):
        cols = [c for c in columns if c // MAX_COLS == band]
        for col in cols:
            for row, s in enumerate(columns[col]):
                pos[s] = (PAD + (col % MAX_COLS) * (BOX_W + COL_GAP), y + row * (BOX_H + ROW_GAP))
        y += max((len(columns[c]) for c in cols), default=0) * (BOX_H + ROW_GAP) + BAND_GAP
    return pos


def machine_svg(machine: dict[str, Any], time_in: dict[str, float] | None = None) -> str:
    """One machine as an ``<svg>`` element. ``time_in`` maps visited states to sim seconds spent there."""
    time_in = time_in or {}
    edges = _edges(machine)
    pos = _positions(machine, _layers(machine, edges))
    box = _Box()
    for x, y in pos.values():
        box.add(x - 16, y - 16)
        box.add(x + BOX_W, y + BOX_H)
    body = []
    x0, y0 = pos[machine["initial"]]
    body.append(f'<circle cx="{x0 - 12}" cy="{y0 - 12}" r="6" fill="#222"/>'
                f'<line x1="{x0 - 8}" y1="{y0 - 8}" x2="{x0}" y2="{y0}" stroke="#222" marker-end="url(#arr)"/>')
    for a, b, label in edges:
        body.append(_arrow(pos[a], pos[b], label, a == b, box))
    timeouts = machine.get("timeouts", {})
    for s, (x, y) in pos.items():
        visited = s in time_in
        fill = "#cfe8cf" if visited else "#f4f4f4"
        sub = f"{time_in[s]:.2f} s" if visited else (f"timeout {timeouts[s]:g} s" if s in timeouts else "")
        body.append(f'<g class="state{" visited" if visited else ""}"><rect x="{x}" y="{y}" width="{BOX_W}" '
                    f'height="{BOX_H}" rx="8" fill="{fill}" stroke="#444"/>'
                    f'<text x="{x + BOX_W / 2}" y="{y + 17}" text-anchor="middle" font-size="12" '
                    f'font-weight="bold">{escape(s)}</text>'
                    f'<text x="{x + BOX_W / 2}" y="{y + 32}" text-anchor="middle" font-size="10" fill="#555">'
                    f'{escape(sub)}</text></g>')
    for trigger, dest, sources in _any_state(machine):
        everywhere = len(sources) == len(machine["states"])
        text = (f"{trigger} \u2192 {dest}   from any state" if everywhere else
                f"{trigger} \u2192 {dest}   from {len(sources)} states")
        y = box.hi[1] + 18
        body.append(f'<text class="any-state" x="{box.lo[0] + 4}" y="{y}" font-size="11" fill="#1f4e8c">'
                    f'<title>from {escape(", ".join(sources))}</title>{escape(text)}</text>')
        box.add(box.lo[0] + 4 + len(text) * 6.0, y + 6)
    lo_x, lo_y = box.lo[0] - PAD / 2, box.lo[1] - PAD / 2
    width, height = box.hi[0] - lo_x + PAD / 2, box.hi[1] - lo_y + PAD / 2
    return (f'<svg xmlns="http://www.w3.org/2000/svg" class="fsm" width="{width:.0f}" height="{height:.0f}" '
            f'viewBox="{lo_x:.1f} {lo_y:.1f} {width:.1f} {height:.1f}" role="img" '
            f'aria-label="state machine {escape(machine["name"])}">'
            '<defs><marker id="arr" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
            'orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>'
            + "".join(body) + "</svg>")


class _Box:
    """The drawing's extent, grown by every box, curve and label, so the view box clips nothing."""

    def __init__(self) -> None:
        self.lo, self.hi = [float("inf")] * 2, [float("-inf")] * 2

    def add(self, x: float, y: float) -> None:
        self.lo = [min(self.lo[0], x), min(self.lo[1], y)]
        self.hi = [max(self.hi[0], x), max(self.hi[1], y)]


def _arrow(a: tuple[float, float], b: tuple[float, float], label: str, loop: bool, box: _Box) -> str:
    ax, ay = a[0] + BOX_W / 2, a[1] + BOX_H / 2
    bx, by = b[0] + BOX_W / 2, b[1] + BOX_H / 2
    if loop:
        path = f"M{a[0] + BOX_W - 20},{a[1]} C{a[0] + BOX_W + 10},{a[1] - 30} {a[0] + BOX_W + 30},{a[1] + 10} " \
               f"{a[0] + BOX_W},{a[1] + 14}"
        lx, ly = a[0] + BOX_W + 6, a[1] - 14
        box.add(a[0] + BOX_W + 30, a[1] - 30)
    elif b[1] > a[1] + BOX_H and bx < ax:  # wrapped onto a later band: down from the bottom to the next top
        sx, sy, ex, ey = ax, a[1] + BOX_H, bx, b[1]
        mx, my = (sx + ex) / 2, (sy + ey) / 2
        path = f"M{sx},{sy} C{sx},{my} {ex},{my} {ex},{ey}"
        lx, ly = mx, my - 3
    else:
        sx = a[0] + BOX_W if bx > ax else (a[0] if bx < ax else ax)
        ex = b[0] if bx > ax else (b[0] + BOX_W if bx < ax else bx)
        sy = ay if bx != ax else (a[1] + BOX_H if by > ay else a[1])
        ey = by if bx != ax else (b[1] if by > ay else b[1] + BOX_H)
        bend = 0.0 if bx > ax else 40.0  # backward edges arc above/below so they do not hide forward ones
        mx, my = (sx + ex) / 2, (sy + ey) / 2 - bend
        path = f"M{sx},{sy} Q{mx},{my - bend} {ex},{ey}"
        lx, ly = mx, my - bend / 2 - 3
        box.add(mx, my - bend)
    short = _short(label)
    half = len(short) * CHAR_W / 2
    box.add(lx - half, ly - 10)
    box.add(lx + half, ly + 3)
    return (f'<path d="{path}" fill="none" stroke="#555" stroke-width="1.2" marker-end="url(#arr)">'
            f'<title>{escape(label)}</title></path>'
            f'<text x="{lx}" y="{ly}" text-anchor="middle" font-size="9" fill="#1f4e8c">{escape(short)}</text>')


def _short(label: str, width: int = 28) -> str:
    return label if len(label) <= width else label[: width - 1] + "…"


def mermaid_text(machine: dict[str, Any]) -> str:
    """The machine as Mermaid ``stateDiagram-v2`` source (shown on the page for copying into other tools)."""
    lines = ["stateDiagram-v2", f"    [*] --> {machine['initial']}"]
    everything = {(a, b): label for a, b, label in _edges(machine, everything=True)}
    for (a, b), label in everything.items():
        lines.append(f"    {a} --> {b}: {label}")
    return "\n".join(lines) + "\n"
