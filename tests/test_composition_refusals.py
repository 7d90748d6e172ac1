"""``robokit validate`` refuses exactly what a composition would fail on at run time, each in one line with its key:
two parallel children commanding one actuator, a monitor that commands, a timeout of 0 s, and a parallel whose
success policy can never be met. Every refused config is then run without the check (``make_sim``), to show that it
does fail; a config next to each, differing only in what was refused, validates and runs."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest

from robokit.cli import main
from robokit.testing import make_sim, validate_error

BOT: dict[str, Any] = {
    "world": {"max_time": 3.0, "seed": 2},
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
               "wall": {"shape": "box", "size": [0.1, 1.0, 0.3], "mass": 0, "position": [3.0, 0, 0.15]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
    "sensors": {"bump": {"type": "contact", "body": "robot", "other": "wall"}},
    "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
}
OUT = {"type": "go_to_goal", "goal": [0.5, 0.0], "scan": ""}
LOG = {"type": "record", "components": ["drive"], "duration": 0}
GUARD = {"type": "guard", "sensor": "bump"}


def config(behaviour: dict[str, Any], monitors: dict[str, Any] | None = None) -> dict[str, Any]:
    raw = copy.deepcopy(BOT)
    raw["behaviour"] = behaviour
    if monitors:
        raw["monitors"] = monitors
    return raw


REFUSED = {
    "two owners": (config({"type": "parallel", "children": [{**OUT, "name": "a"}, {**OUT, "name": "b"}]}),
                   "behaviour.children[1]: 'a' and 'b' both command actuator 'drive'", "error"),
    "commanding monitor": (config({**OUT}, {"pusher": {**OUT, "goal": [-1.0, 0.0]}}),
                           "monitors.pusher: a monitor observes, and type 'go_to_goal' commands drive", "error"),
    "zero timeout": (config({"type": "timeout", "seconds": 0.0, "child": {**OUT}}), "behaviour.seconds: ", None),
    "all with a guard": (config({"type": "parallel", "children": [{**OUT, "name": "out"}, {**GUARD, "name": "g"}]}),
                         "behaviour.success: success = 'all' can never be met: 'g' never succeed", "aborted"),
    "all with an endless record": (
        config({"type": "parallel", "children": [{**OUT, "name": "out"}, {**LOG, "name": "log"}]}),
        "behaviour.success: success = 'all' can never be met: 'log' never succeed", "aborted"),
}
RUNS = {
    "two owners": config({"type": "parallel", "children": [{**OUT, "name": "a"}, {**LOG, "name": "b"}],
                          "success": "one"}),
    "commanding monitor": config({**OUT}, {"log": {**LOG}}),
    "zero timeout": config({"type": "timeout", "seconds": 2.5, "child": {**OUT}}),
    "all with a guard": config({"type": "parallel", "success": "one",
                                "children": [{**OUT, "name": "out"}, {**GUARD, "name": "g"}]}),
    "all with an endless record": config({"type": "parallel", "children": [
        {**OUT, "name": "out"}, {**LOG, "name": "log", "duration": 1.0}]}),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_validate_refuses_what_fails_at_run_time(case: str, tmp_path: Path) -> None:
    from test_compose import _toml  # the suite's tiny TOML writer

    raw, expected, at_run = REFUSED[case]
    path = tmp_path / "c.toml"
    path.write_text(_toml(raw))
    line = validate_error(path)
    assert expected in line, line
    if at_run is None:  # refused by the schema: no simulation can be built from it
        return
    with make_sim(raw) as sim:
        result = sim.run()
    assert result.outcome == at_run, result.reason
    if at_run == "aborted":
        assert result.reason.startswith("max_time 3 s reached")  # the policy was never met


@pytest.mark.parametrize("case", list(RUNS))
def test_the_same_config_without_the_fault_validates_and_succeeds(case: str, tmp_path: Path) -> None:
    from test_compose import _toml

    path = tmp_path / "c.toml"
    path.write_text(_toml(RUNS[case]))
    assert main(["validate", str(path)]) == 0
    with make_sim(RUNS[case]) as sim:
        result = sim.run()
    assert result.outcome == "succeeded", result.reason
