"""More than one behaviour per config: monitors beside the task, sequences of behaviours, `robokit graph CONFIG`."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from robokit import hookimpl
from robokit.cli import main
from robokit.components import Behaviour
from robokit.config import Schema
from robokit.msgs import Twist
from robokit.testing import make_sim, validate_error

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"

SCENE: dict[str, Any] = {
    "world": {"max_time": 20.0, "seed": 2},
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
    "sensors": {"scan": {"type": "lidar", "rays": 36, "rate_hz": 10}},
    "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
}


def scene(behaviour: dict[str, Any] | None = None, **monitors: dict[str, Any]) -> dict[str, Any]:
    raw = json.loads(json.dumps(SCENE))
    if behaviour is not None:
        raw["behaviour"] = behaviour
    if monitors:
        raw["monitors"] = monitors
    return raw


GOAL = {"type": "go_to_goal", "goal": [1.0, 0.5]}


def run(raw: dict[str, Any], **kwargs: Any) -> tuple[Any, list[dict[str, Any]]]:
    with make_sim(raw, **kwargs) as sim:
        result = sim.run()
        return result, list(sim.trace)


def test_a_monitor_records_beside_the_task_without_changing_the_run() -> None:
    alone, alone_trace = run(scene(GOAL))
    logged, trace = run(scene(GOAL, log={"type": "record", "components": ["drive"], "rate_hz": 5,
                                         "duration": 0}))
    assert alone.outcome == logged.outcome == "succeeded"
    assert logged.ticks == alone.ticks and logged.result["final_position"] == alone.result["final_position"]
    transitions = [r for r in alone_trace if r["kind"] == "transition"]
    assert [r for r in trace if r["kind"] == "transition"] == transitions  # the monitor changed nothing
    readings = [r for r in trace if r["kind"] == "reading"]
    assert all(r["source"] == "log" and r["component"] == "drive" for r in readings)
    assert [r["tick"] for r in readings[:3]] == [0, 48, 96]  # 5 Hz of 240 Hz physics
    monitor = logged.result["monitors"]["log"]
    assert monitor["type"] == "record" and monitor["outcome"] == "running"
    assert monitor["recorded"] == {"drive": len(readings)} == {"drive": (logged.ticks - 1) // 48 + 1}


def test_a_monitor_that_finishes_early_stops_while_the_task_goes_on() -> None:
    result, trace = run(scene(GOAL, short={"type": "record", "components": ["drive"], "duration": 0.5,
                                           "rate_hz": 10}))
    assert result.outcome == "succeeded" and result.sim_time > 1.0
    short = result.result["monitors"]["short"]
    assert short["outcome"] == "succeeded" and short["recorded"] == {"drive": 6}  # t = 0, 0.1, ..., 0.5
    assert max(r["t"] for r in trace if r["source"] == "short") == 0.5


class PushConfig(Schema):
    """No options."""


class Pusher(Behaviour):
    """Sends a drive command (a monitor must not)."""

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        return {"drive": Twist(0.1, 0.0)}


class Crasher(Behaviour):
    """Divides by zero at its third step (a bug in a monitor)."""

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        self.n = getattr(self, "n", 0) + 1
        if self.n == 3:
            print(1 / 0)


class PushPlugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("pusher", Pusher, PushConfig)
        register("crasher", Crasher, PushConfig)


def test_a_monitor_that_commands_an_actuator_ends_the_run_with_an_error_naming_it() -> None:
    result, _ = run(scene(GOAL, rogue={"type": "pusher"}), extra_plugins=[PushPlugin()])
    assert result.outcome == "error"
    assert result.reason.startswith("monitor 'rogue' (type 'pusher' from <local>) sent commands to drive: monitors "
                                    "observe; only the task ([behaviour]) commands actuators")


def test_a_monitor_that_raises_is_named_with_the_file_and_line() -> None:
    result, trace = run(scene(GOAL, buggy={"type": "crasher", "rate_hz": 10}), extra_plugins=[PushPlugin()])
    assert result.outcome == "error" and result.ticks == 48  # its third step, at t = 0.2 s
    assert result.reason.startswith("monitor 'buggy' (type 'crasher' from <local>) raised during step: "
                                    "ZeroDivisionError: division by zero (at tests/test_compose.py:")
    assert trace[-1]["kind"] == "error" and trace[-1]["reason"] == result.reason


def test_a_sequence_runs_its_steps_in_order_each_on_its_own_clock() -> None:
    steps = [{**GOAL, "name": "out"}, {"type": "go_to_goal", "goal": [0.0, 0.0], "timeout": 15.0}]
    result, trace = run(scene({"type": "sequence", "steps": steps}))
    assert result.outcome == "succeeded" and result.reason == "all 2 steps succeeded"
    out, back = result.result["steps"]
    assert (out["name"], out["outcome"], back["name"], back["outcome"]) == ("out", "succeeded", "go_to_goal",
                                                                            "succeeded")
    assert back["started_at"] == pytest.approx(out["sim_time"] + 1 / 240)
    assert back["result"]["distance_to_goal"] <= 0.2 and result.result["steps_completed"] == 2
    marks = [(r["kind"], r["step"]) for r in trace if r["kind"] in ("step_start", "step_end")]
    assert marks == [("step_start", "out"), ("step_end", "out"), ("step_start", "go_to_goal"),
                     ("step_end", "go_to_goal")]
    # each step's machine writes its transitions under its own name
    assert {r["machine"] for r in trace if r["kind"] == "transition"} == {"out", "go_to_goal"}
    # the second step's timeout counts from its own start: 15 s would already be gone on the run's clock otherwise
    assert out["sim_time"] < 15.0 < result.sim_time + 15.0


def test_a_failing_step_ends_the_sequence_and_later_steps_never_start() -> None:
    steps = [{**GOAL, "timeout": 0.5}, {"type": "go_to_goal", "goal": [0.0, 0.0]}]
    result, _ = run(scene({"type": "sequence", "steps": steps}))
    assert result.outcome == "failed"
    assert result.reason.startswith("step 1 'go_to_goal_1' (go_to_goal) failed: ")
    assert [s["outcome"] for s in result.result["steps"]] == ["failed", "not started"]


@pytest.mark.parametrize("behaviour,monitors,expected", [
    ({"type": "sequence"}, {}, "behaviour.steps: a sequence needs steps"),
    ({"type": "sequence", "steps": [GOAL, {"type": "go_to_gaol"}]}, {},
     "behaviour.steps[1].type: unknown behaviour type 'go_to_gaol' (did you mean 'go_to_goal'?)"),
    ({"type": "sequence", "steps": [{**GOAL, "speed": 1}]}, {}, "behaviour.steps[0].speed: unknown key 'speed'"),
    ({"type": "sequence", "steps": [{**GOAL, "name": "a"}, {**GOAL, "name": "a"}]}, {},
     "behaviour.steps[0].name: two steps are named 'a'"),
    (GOAL, {"m": {"type": "sequence", "steps": [GOAL]}}, "monitors.m: a monitor cannot be a sequence"),
    (GOAL, {"m": {"type": "record", "components": ["nope"]}}, "monitors.m.components[0]: unknown sensor or actuator"),
])
def test_composition_config_errors_are_one_line_with_the_key(tmp_path: Path, behaviour: dict[str, Any],
                                                              monitors: dict[str, Any], expected: str) -> None:
    path = tmp_path / "c.toml"  # written as TOML, the way a user writes it
    path.write_text(_toml(scene(behaviour, **monitors)))
    line = validate_error(path)
    assert expected in line, line


def _toml(raw: dict[str, Any], prefix: str = "") -> str:
    """A tiny TOML writer for the nested tables and arrays of tables these tests use."""
    out, tables = [], []
    for key, value in raw.items():
        if isinstance(value, dict):
            tables.append((key, value))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            tables.append((key, value))
        else:
            out.append(f"{key} = {json.dumps(value)}")
    text = "\n".join(out) + "\n"
    for key, value in tables:
        name = f"{prefix}{key}"
        if isinstance(value, list):
            for item in value:
                text += f"\n[[{name}]]\n" + _toml(item, f"{name}.")
        else:
            text += f"\n[{name}]\n" + _toml(value, f"{name}.")
    return text


def test_graph_of_a_config_draws_the_sequence_and_the_monitors(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "composed.toml"
    steps = [{**GOAL, "name": "out"}, {"type": "go_to_goal", "goal": [0.0, 0.0]}]
    path.write_text(_toml(scene({"type": "sequence", "steps": steps}, log={"type": "record"})))
    assert main(["graph", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("stateDiagram-v2\n")
    for line in ('state "task: sequence of 2" as task {', 'state "1. out (go_to_goal)" as task_1 {',
                 "task_1_TURNING --> task_1_DRIVING: aligned", "[*] --> task_1", "task_1 --> task_2: succeeded",
                 "task_2 --> [*]", "--", 'state "monitor log (record)" as m_log {'):
        assert line in out, line
    assert main(["graph", str(CONFIGS / "patrol_logged.toml")]) == 0
    out = capsys.readouterr().out
    assert 'state "task: patrol" as task {' in out and 'state "monitor path (record)" as m_path {' in out


def test_graph_of_a_behaviour_type_still_works(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["graph", "pick_place"]) == 0
    assert "APPROACH --> DESCEND: above_object" in capsys.readouterr().out


@pytest.mark.slow
def test_the_logged_patrol_config_records_the_path_beside_the_patrol(tmp_path: Path, monkeypatch: Any,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    trace = tmp_path / "patrol.jsonl"
    assert main(["run", str(CONFIGS / "patrol_logged.toml"), "--json", "--trace", str(trace)]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "succeeded" and result["result"]["waypoints_reached"] == 3
    path = [json.loads(line) for line in trace.read_text().splitlines()]
    poses = [r["value"]["pose"] for r in path if r.get("kind") == "reading" and r.get("source") == "path"]
    assert len(poses) == result["result"]["monitors"]["path"]["recorded"]["drive"] > 50
    assert max(p[0] for p in poses) > 4.5  # the logged path reaches the far waypoints
