"""The state diagrams of a run page and of ``mermaid()`` read back and compared with the machine they draw, over
generated machines.

Machines are generated (states, transitions from one state, from a list, from ``*``, self-loops, the same pair by
several triggers, timeouts), and each drawing is read back: the Mermaid text names every (source, dest) pair once with
its triggers in order; the SVG draws an arrow per pair of the transitions allowed from fewer than three states, lists
each transition allowed from more under the drawing ("from any state" or "from N states", its sources in the
tooltip), labels every state box with its time or timeout, and its view box holds every box.
"""

from __future__ import annotations

import html
import re
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.record.diagram import machine_svg, mermaid_text

STATES = ["IDLE", "MOVE", "GRASP", "LIFT", "DONE"]


@st.composite
def machines(draw: st.DrawFn) -> dict[str, Any]:
    states = draw(st.lists(st.sampled_from(STATES), min_size=1, max_size=5, unique=True))
    transitions = []
    for _ in range(draw(st.integers(0, 7))):
        form = draw(st.sampled_from(["one", "list", "any"]))
        source: Any = (draw(st.sampled_from(states)) if form == "one" else "*" if form == "any" else
                       draw(st.lists(st.sampled_from(states), min_size=1, max_size=len(states), unique=True)))
        transitions.append({"trigger": draw(st.sampled_from(["go", "stop", "retry", "give_up"])), "source": source,
                            "dest": draw(st.sampled_from(states))})
    timeouts = draw(st.dictionaries(st.sampled_from(states), st.sampled_from([1.5, 30.0]), max_size=2))
    return {"name": "m<1>", "initial": states[0], "states": states, "transitions": transitions, "timeouts": timeouts}


def sources(m: dict[str, Any], t: dict[str, Any]) -> list[str]:
    return list(m["states"]) if t["source"] == "*" else [t["source"]] if isinstance(t["source"], str) else t["source"]


def pairs(m: dict[str, Any], few_only: bool) -> dict[tuple[str, str], list[str]]:
    out: dict[tuple[str, str], list[str]] = {}
    for t in m["transitions"]:
        if few_only and len(sources(m, t)) >= 3:
            continue
        for s in sources(m, t):
            got = out.setdefault((s, t["dest"]), [])
            if t["trigger"] not in got:
                got.append(t["trigger"])
    return out


@settings(max_examples=40, deadline=None, derandomize=True)
@given(machines())
def test_the_mermaid_text_names_every_transition(m: dict[str, Any]) -> None:
    lines = mermaid_text(m).splitlines()
    assert lines[:2] == ["stateDiagram-v2", f"    [*] --> {m['initial']}"]
    got = [re.fullmatch(r"    (\S+) --> (\S+): (.*)", x).groups() for x in lines[2:]]  # type: ignore[union-attr]
    assert {(a, b): label.split(", ") for a, b, label in got} == pairs(m, few_only=False)
    assert len(got) == len(pairs(m, few_only=False))


@settings(max_examples=40, deadline=None, derandomize=True)
@given(machines(), st.dictionaries(st.sampled_from(STATES), st.floats(0, 100), max_size=3))
def test_the_svg_draws_each_arrow_lists_each_any_state_transition_and_holds_every_box(
        m: dict[str, Any], time_in: dict[str, float]) -> None:
    time_in = {s: v for s, v in time_in.items() if s in m["states"]}
    svg = machine_svg(m, time_in)
    assert f'aria-label="state machine {html.escape(m["name"])}"' in svg
    arrows = [html.unescape(x) for x in re.findall(r'marker-end="url\(#arr\)"><title>(.*?)</title></path>', svg)]
    want = pairs(m, few_only=True)
    assert sorted(arrows) == sorted(", ".join(v) for v in want.values())
    listed = re.findall(r'<text class="any-state"[^>]*><title>from (.*?)</title>(.*?)</text>', svg)
    many = [t for t in m["transitions"] if len(sources(m, t)) >= 3]
    assert len(listed) == len(many)
    for (title, text), t in zip(listed, many, strict=True):
        src = sources(m, t)
        assert html.unescape(title) == ", ".join(src)
        where = "from any state" if len(src) == len(m["states"]) else f"from {len(src)} states"
        assert html.unescape(text) == f"{t['trigger']} \u2192 {t['dest']}   {where}"
    boxes = re.findall(r'<g class="state( visited)?"><rect x="([-\d.]+)" y="([-\d.]+)" width="([\d.]+)" '
                       r'height="([\d.]+)".*?font-weight="bold">(.*?)</text>.*?fill="#555">(.*?)</text></g>', svg)
    assert sorted(b[5] for b in boxes) == sorted(m["states"])
    lo_x, lo_y, width, height = (float(v) for v in re.search(r'viewBox="(\S+) (\S+) (\S+) (\S+)"', svg).groups())  # type: ignore[union-attr]
    for visited, x, y, w, h, name, sub in boxes:
        assert (visited == " visited") == (name in time_in)
        assert sub == (f"{time_in[name]:.2f} s" if name in time_in else
                       f"timeout {m['timeouts'][name]:g} s" if name in m["timeouts"] else "")
        assert lo_x <= float(x) and float(x) + float(w) <= lo_x + width  # nothing clipped
        assert lo_y <= float(y) and float(y) + float(h) <= lo_y + height
