"""State machine diagrams as inline SVG, drawn from a record header's machine structure (no JavaScript, offline).

Layout: states in columns by their shortest distance from the initial state (a layered drawing, like Mermaid's
``stateDiagram-v2`` left to right); arrows between boxes, labelled with their triggers; states the run visited
are filled, with the sim seconds spent in them.
"""

from __future__ import annotations

from collections import deque
from html import escape
from typing import Any

BOX_W, BOX_H, COL_GAP, ROW_GAP, PAD = 150, 40, 70, 26, 20


def _edges(machine: dict[str, Any]) -> list[tuple[str, str, str]]:
    out: dict[tuple[str, str], list[str]] = {}
    states = machine["states"]
    for t in machine["transitions"]:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        if "*" in sources:
            sources = states
        for s in sources:
            out.setdefault((s, t["dest"]), []).append(t["trigger"])
    return [(s, d, ", ".join(dict.fromkeys(triggers))) for (s, d), triggers in out.items()]


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


def machine_svg(machine: dict[str, Any], time_in: dict[str, float] | None = None) -> str:
    """One machine as an ``<svg>`` element. ``time_in`` maps visited states to sim seconds spent there."""
    time_in = time_in or {}
    edges = _edges(machine)
    depth = _layers(machine, edges)
    columns: dict[int, list[str]] = {}
    for s in machine["states"]:
        columns.setdefault(depth[s], []).append(s)
    pos = {}
    for col, names in columns.items():
        for row, s in enumerate(names):
            pos[s] = (PAD + col * (BOX_W + COL_GAP), PAD + 24 + row * (BOX_H + ROW_GAP))
    width = PAD * 2 + (max(columns) + 1) * (BOX_W + COL_GAP) - COL_GAP
    height = PAD * 2 + 24 + max(len(v) for v in columns.values()) * (BOX_H + ROW_GAP)
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" class="fsm" width="{width}" height="{height}" '
             f'viewBox="0 0 {width} {height}" role="img" aria-label="state machine {escape(machine["name"])}">',
             '<defs><marker id="arr" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7" '
             'orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#555"/></marker></defs>']
    x0, y0 = pos[machine["initial"]]
    parts.append(f'<circle cx="{x0 - 12}" cy="{y0 - 12}" r="6" fill="#222"/>'
                 f'<line x1="{x0 - 8}" y1="{y0 - 8}" x2="{x0}" y2="{y0}" stroke="#222" marker-end="url(#arr)"/>')
    for a, b, label in edges:
        parts.append(_arrow(pos[a], pos[b], label, a == b))
    timeouts = machine.get("timeouts", {})
    for s, (x, y) in pos.items():
        visited = s in time_in
        fill = "#cfe8cf" if visited else "#f4f4f4"
        sub = f"{time_in[s]:.2f} s" if visited else (f"timeout {timeouts[s]:g} s" if s in timeouts else "")
        parts.append(f'<g class="state{" visited" if visited else ""}"><rect x="{x}" y="{y}" width="{BOX_W}" '
                     f'height="{BOX_H}" rx="8" fill="{fill}" stroke="#444"/>'
                     f'<text x="{x + BOX_W / 2}" y="{y + 17}" text-anchor="middle" font-size="12" '
                     f'font-weight="bold">{escape(s)}</text>'
                     f'<text x="{x + BOX_W / 2}" y="{y + 32}" text-anchor="middle" font-size="10" fill="#555">'
                     f'{escape(sub)}</text></g>')
    parts.append("</svg>")
    return "".join(parts)


def _arrow(a: tuple[float, float], b: tuple[float, float], label: str, loop: bool) -> str:
    ax, ay = a[0] + BOX_W / 2, a[1] + BOX_H / 2
    bx, by = b[0] + BOX_W / 2, b[1] + BOX_H / 2
    if loop:
        path = f"M{a[0] + BOX_W - 20},{a[1]} C{a[0] + BOX_W + 10},{a[1] - 30} {a[0] + BOX_W + 30},{a[1] + 10} " \
               f"{a[0] + BOX_W},{a[1] + 14}"
        lx, ly = a[0] + BOX_W + 6, a[1] - 14
    else:
        sx = a[0] + BOX_W if bx > ax else (a[0] if bx < ax else ax)
        ex = b[0] if bx > ax else (b[0] + BOX_W if bx < ax else bx)
        sy = ay if bx != ax else (a[1] + BOX_H if by > ay else a[1])
        ey = by if bx != ax else (b[1] if by > ay else b[1] + BOX_H)
        bend = 0.0 if bx > ax else 40.0  # backward edges arc above/below so they do not hide forward ones
        mx, my = (sx + ex) / 2, (sy + ey) / 2 - bend
        path = f"M{sx},{sy} Q{mx},{my - bend} {ex},{ey}"
        lx, ly = mx, my - bend / 2 - 3
    return (f'<path d="{path}" fill="none" stroke="#555" stroke-width="1.2" marker-end="url(#arr)">'
            f'<title>{escape(label)}</title></path>'
            f'<text x="{lx}" y="{ly}" text-anchor="middle" font-size="9" fill="#1f4e8c">{escape(_short(label))}</text>')


def _short(label: str, width: int = 28) -> str:
    return label if len(label) <= width else label[: width - 1] + "…"


def mermaid_text(machine: dict[str, Any]) -> str:
    """The machine as Mermaid ``stateDiagram-v2`` source (shown on the page for copying into other tools)."""
    lines = ["stateDiagram-v2", f"    [*] --> {machine['initial']}"]
    for a, b, label in _edges(machine):
        lines.append(f"    {a} --> {b}: {label}")
    return "\n".join(lines) + "\n"
