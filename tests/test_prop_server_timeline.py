"""The run page's state timeline against the trace it was drawn from, over generated traces.

A run's uploaded ``trace.jsonl`` (a header line, then records) is drawn on the course server's run page as one lane
per state machine -- a bar of its states, each segment as wide as its stay -- and a table of every transition. Here
traces are generated (machines that start late, states entered twice, records of other kinds and transitions
without a number for a time mixed in) and the page is read back as a visitor gets it: each table row against its
transition record, each lane's segments against a plain walk of that machine's transitions. A segment's width is
its share of the run's sim time, and the segments of a lane follow each other from t = 0, so each one's left edge
is where its stay began: the first one is the state the machine was in before its first transition.
"""

from __future__ import annotations

import html
import itertools
import json
import re
from typing import Any

import pytest
from course_helpers import PASSWORD, post, robokit_payload
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=8, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
STATES = ("WAIT", "LOOK", "PICK", "PLACE", "DONE", "조립", "A<&>B")
_runs = itertools.count(100)


@st.composite
def traces(draw: Any) -> tuple[list[dict[str, Any]], list[str], float]:
    """Transition records of 1-3 machines in time order (sim times on the 240 Hz clock), other lines between."""
    machines = draw(st.lists(st.sampled_from(["behaviour", "pick", "nav"]), min_size=1, max_size=3, unique=True))
    state = {m: draw(st.sampled_from(STATES)) for m in machines}
    tick, records, lines = 0, [], []
    for _ in range(draw(st.integers(1, 12))):
        tick += draw(st.integers(0, 600))
        m = draw(st.sampled_from(machines))
        dest = draw(st.sampled_from([s for s in STATES if s != state[m]]))
        rec = {"kind": "transition", "t": round(tick / 240, 6), "tick": tick, "machine": m,
               "source_state": state[m], "dest_state": dest, "trigger": draw(st.sampled_from(["go", "found", "보다"]))}
        state[m] = dest
        records.append(rec)
        lines.append(json.dumps(rec, ensure_ascii=False))
        extra = draw(st.sampled_from([None, "step", "bad-t"]))
        if extra == "step":
            lines.append(json.dumps({"kind": "step_start", "t": rec["t"], "step": "x"}))
        elif extra == "bad-t":
            lines.append(json.dumps({**rec, "t": "soon", "dest_state": "NEVER"}))
    header = json.dumps({"kind": "header", "schema": "robokit.record/1",
                         "machines": [{"name": m, "initial": records[0]["source_state"]} for m in machines]})
    sim_time = draw(st.sampled_from([0.0, records[-1]["t"], records[-1]["t"] + 2.5]))
    return records, [header, *lines], sim_time


def expected_lanes(records: list[dict[str, Any]], end: float) -> dict[str, list[tuple[str, float, float]]]:
    """Per machine, (state, start, end) from 0 to the end: before its first transition, that transition's source."""
    lanes: dict[str, list[tuple[str, float, float]]] = {}
    for r in records:
        lane = lanes.setdefault(r["machine"], [])
        if not lane and r["t"] > 0:
            lane.append((r["source_state"], 0.0, r["t"]))
        if lane:
            lane[-1] = (lane[-1][0], lane[-1][1], r["t"])
        lane.append((r["dest_state"], r["t"], end))
    return lanes


LANE = re.compile(r'<div class="lane"><span class="machine">(.*?)</span><div class="bar">(.*?)</div></div>', re.S)
SEG = re.compile(r'<span class="seg c(\d+)" style="width: ([0-9.]+)%" title="(.*?) ([0-9.]+)–([0-9.]+) s">(.*?)</span>',
                 re.S)
ROW = re.compile(r'<tr><td class="num">([0-9.]+)</td><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td></tr>')


@pytest.fixture
def teacher_client(client: Any, course: Any) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


@PROPS
@given(traces())
def test_every_timeline_row_and_segment_is_its_transition_record(teacher_client: Any, course: Any, settings: Any,
                                                                tmp_path_factory: Any, trace: Any) -> None:
    from django.core.files.uploadedfile import SimpleUploadedFile

    records, lines, sim_time = trace
    settings.MEDIA_ROOT = tmp_path_factory.mktemp("media")
    payload = robokit_payload(next(_runs))
    payload["sim_time"] = sim_time
    payload["total_time"] = sim_time
    assert post(teacher_client, payload, course.kim_token).status_code == 201
    up = teacher_client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                             data={"f": SimpleUploadedFile("trace.jsonl", "\n".join(lines).encode())},
                             HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert up.status_code == 201, up.content
    page = teacher_client.get(f"/runs/{payload['run_id']}/").content.decode()
    timeline = page[page.index("<h2>State timeline</h2>"):page.index("<h2>Config</h2>")]

    rows = [(float(t), *map(html.unescape, rest)) for t, *rest in ROW.findall(timeline)]
    assert len(rows) == len(records)
    for (t, machine, src, dest, trigger), r in zip(rows, records, strict=True):
        assert abs(t - r["t"]) <= 0.0005 + 1e-9
        assert (machine, src, dest, trigger) == (r["machine"], r["source_state"], r["dest_state"], r["trigger"])

    end = max(sim_time, records[-1]["t"]) or 1.0
    want = expected_lanes(records, end)
    lanes = {html.unescape(m): SEG.findall(bar) for m, bar in LANE.findall(timeline)}
    assert list(lanes) == list(want)
    colour: dict[str, str] = {}
    for machine, segs in lanes.items():
        assert len(segs) == len(want[machine]), machine
        for (c, width, state, start, stop, label), (w_state, w_start, w_end) in zip(segs, want[machine], strict=True):
            assert html.unescape(state) == html.unescape(label) == w_state
            assert abs(float(start) - w_start) <= 0.005 + 1e-9 and abs(float(stop) - w_end) <= 0.005 + 1e-9
            assert float(width) == pytest.approx((w_end - w_start) / end * 100, abs=1e-3)
            assert colour.setdefault(w_state, c) == c  # one state, one colour, in every lane
        assert sum(float(s[1]) for s in segs) == pytest.approx(100.0, abs=0.01)  # a lane spans the whole run


def test_a_long_trace_and_a_long_korean_config_are_shown_whole(teacher_client: Any, course: Any, settings: Any,
                                                                tmp_path: Any) -> None:
    """Traces are taken up to 20 MiB and configs up to 256 KiB: a trace whose transitions come after 250 KB of
    other records still has them all on the page, for a run that reported no sim time (the bars end at the last
    transition); a config of Korean text cut for display inside a character still shows (never a 500)."""
    from django.core.files.uploadedfile import SimpleUploadedFile

    settings.MEDIA_ROOT = tmp_path / "media"
    payload = robokit_payload(next(_runs))
    for key in ("sim_time", "total_time"):
        payload.pop(key, None)
        payload.get("result", {}).pop(key, None)
    assert post(teacher_client, payload, course.kim_token).status_code == 201
    ticks = [json.dumps({"kind": "sample", "t": i / 100, "pad": "x" * 100}) for i in range(2200)]
    moves = [{"kind": "transition", "t": t, "machine": "arm", "source_state": a, "dest_state": b, "trigger": "go"}
             for t, a, b in ((0.2, "idle", "reach"), (0.4, "reach", "grip"), (0.6, "grip", "lift"))]
    trace = "\n".join([json.dumps({"kind": "header"}), *ticks, *map(json.dumps, moves)]).encode()
    assert len(trace) > 250_000
    config = ("#  " + "가" * 70_000 + "\n[world]\nmax_time = 1.0\n").encode()  # byte 200,000 is inside a character
    assert 200_000 < len(config) < 256 * 1024 and (200_000 - 3) % 3
    up = teacher_client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                             data={"t": SimpleUploadedFile("trace.jsonl", trace),
                                   "c": SimpleUploadedFile("mine.toml", config)},
                             HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
    assert up.status_code == 201, up.content
    got = teacher_client.get(f"/runs/{payload['run_id']}/")
    assert got.status_code == 200
    page = got.content.decode()
    timeline = page[page.index("<h2>State timeline</h2>"):page.index("<h2>Config</h2>")]
    rows = [(float(t), *map(html.unescape, rest)) for t, *rest in ROW.findall(timeline)]
    assert rows == [(m["t"], "arm", m["source_state"], m["dest_state"], "go") for m in moves]
    (bar,) = [SEG.findall(b) for _, b in LANE.findall(timeline)]
    widths = [float(s[1]) for s in bar]  # idle 0-0.2, reach 0.2-0.4, grip 0.4-0.6, lift 0.6-0.6 of 0.6 s
    assert widths == pytest.approx([100 / 3, 100 / 3, 100 / 3, 0.0], abs=1e-3)
    assert "가" * 100 in page[page.index("<h2>Config</h2>"):]
