"""Monitors that act: a guard that aborts the run (the arm stopped within one control period of the contact, in the
shipped configs/contact_abort.toml), a guard that pre-empts the task into a named recovery, ``make_sim``'s
monitor results, composites on real physics, composition config errors, and ``robokit graph`` of a nested tree."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest

from robokit.cli import main
from robokit.config import read_toml
from robokit.testing import make_sim, validate_error

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"

WRIST_BOUND = 250.0
"""N: the wrist force (force_torque at panda_hand_joint) after the guard's stop stays below this; the same arm
without the guard presses on with more than 350 N from 0.1 s after the contact on (measured in the same test)."""


def _first_contact_tick(raw: dict[str, Any]) -> tuple[int, list[float]]:
    """Run the scene without the guard; the first tick after whose physics step the Panda touches the table
    (pybullet's contact points, not robokit's sensor), and the wrist force every tick of the second after it."""
    raw = copy.deepcopy(raw)
    del raw["monitors"]
    with make_sim(raw, base_dir=CONFIGS) as sim:
        w = sim.world
        panda, table = w.body("panda"), w.body("table")
        first = None
        while first is None and w.tick < 2400:
            sim.step()
            if w.client.getContactPoints(bodyA=panda, bodyB=table):
                first = w.tick  # contact exists at the start of this tick: a sensor read now sees it
        assert first is not None
        forces = []
        for _ in range(240):
            forces.append(math.dist(sim.readings["wrist"].force, (0.0, 0.0, 0.0)))
            sim.step()
        return first, forces


def test_a_contact_guard_aborts_and_stops_the_arm_within_one_control_period() -> None:
    raw = read_toml(CONFIGS / "contact_abort.toml")
    contact_tick, unguarded = _first_contact_tick(raw)
    with make_sim(raw, base_dir=CONFIGS) as sim:
        result = sim.run()
        assert result.outcome == "aborted"
        assert result.reason.startswith("aborted by monitor 'guard' (guard): contact with table (")
        stops = [r for r in sim.trace if r["kind"] == "protective_stop"]
        assert {r["actuator"] for r in stops} == {"arm", "gripper"}
        # the stop is sent in the tick the contact is first seen, before that tick's physics step
        assert {r["tick"] for r in stops} == {contact_tick}
        assert [r["tick"] for r in sim.trace if r["kind"] == "monitor_abort"] == [contact_tick]
        monitors = sim.monitor_results()
        assert monitors["guard"]["outcome"] == "aborted" and monitors["guard"]["action"] == "abort"
        assert monitors["guard"]["acted_at"] == pytest.approx(contact_tick / 240, abs=1e-6)
        assert result.result["monitors"] == monitors
        assert sim.readings["arm"].stopped and sim.readings["arm"].failed
        # after the stop: the joints' speed drops to a quarter or less in the next control period (the arm's
        # is every tick), the hand goes no further down (only the contact's rebound, < 1 mm), the joints are all
        # but still (< 0.02 rad/s: the contact chatters) within 50 ms, and the wrist force stays below the bound
        # while the unguarded arm presses on
        panda = sim.world.body("panda")
        c = sim.world.client
        speed_at_stop = max(abs(st[1]) for st in c.getJointStates(panda, range(7)))
        z_at_stop = sim.readings["arm"].position[2]
        guarded, lowest = [], z_at_stop
        for k in range(240):
            sim.step()
            speed = max(abs(st[1]) for st in c.getJointStates(panda, range(7)))
            if k == 0:
                assert speed < 0.25 * speed_at_stop, (speed, speed_at_stop)
            if k >= 12:
                assert speed < 0.02, (k, speed)
            lowest = min(lowest, sim.readings["arm"].position[2])
            guarded.append(math.dist(sim.readings["wrist"].force, (0.0, 0.0, 0.0)))
    assert speed_at_stop > 0.3  # it was moving when it touched
    assert lowest > z_at_stop - 0.001
    assert max(guarded) < WRIST_BOUND < 350.0 < min(unguarded[24:])


def test_the_shipped_abort_config_runs_from_the_cli(tmp_path: Path, monkeypatch: Any,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(CONFIGS / "contact_abort.toml"), "--json", "--no-record"]) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "aborted" and result["result"]["monitors"]["guard"]["outcome"] == "aborted"


BOT: dict[str, Any] = {
    "world": {"max_time": 20.0, "seed": 2},
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
               "wall": {"shape": "box", "size": [0.1, 1.0, 0.3], "mass": 0, "position": [1.0, 0, 0.15]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
    "sensors": {"bump": {"type": "contact", "body": "robot", "other": "wall"}},
    "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}},
    "behaviour": {"type": "go_to_goal", "goal": [2.0, 0.0], "scan": ""},
    "monitors": {"guard": {"type": "guard", "sensor": "bump", "action": "recover", "recovery": "back_off"}},
    "recoveries": {"back_off": {"type": "go_to_goal", "goal": [0.0, 0.0], "scan": "", "tolerance": 0.1}},
}


def test_a_guard_pre_empts_the_task_into_its_named_recovery() -> None:
    raw = copy.deepcopy(BOT)
    raw["monitors"]["guard"]["watch_recovery"] = False  # turning away, the robot brushes the wall again
    with make_sim(raw) as sim:
        result = sim.run()
        trace = sim.trace
        x, y, _ = sim.readings["drive"].pose
    assert result.outcome == "aborted"  # the task did not finish; the recovery did
    assert result.reason.startswith("pre-empted at t = ") and "by monitor 'guard' (guard): contact with wall" in \
        result.reason and "; recovery 'back_off' succeeded: within " in result.reason
    guard = result.result["monitors"]["guard"]
    assert guard["action"] == "recover" and guard["recovery"]["outcome"] == "succeeded"
    kinds = [r["kind"] for r in trace if r["kind"] in ("monitor_preempt", "recovery_end")]
    assert kinds == ["monitor_preempt", "recovery_end"]
    preempt = next(r for r in trace if r["kind"] == "monitor_preempt")
    # the recovery's machine starts the tick after the pre-emption; the task never steps again
    assert min(r["tick"] for r in trace if r.get("machine") == "back_off") >= preempt["tick"] + 1
    assert max((r["tick"] for r in trace if r.get("machine") == "behaviour"), default=-1) <= preempt["tick"]
    assert math.hypot(x, y) <= 0.1 + 0.02  # back where it started (the recovery's tolerance)


def test_the_guard_watching_the_recovery_stops_it_when_it_touches_the_wall_again() -> None:
    with make_sim(BOT) as sim:
        touching = []
        while sim.outcome is None and sim.world.tick < 4800:
            sim.step()
            points = sim.world.client.getContactPoints(bodyA=sim.world.body("robot"), bodyB=sim.world.body("wall"))
            touching.append(any(p[9] > 0 for p in points))  # a normal force: pushing, not just near
        result = sim.run()
        trace = sim.trace
    preempt = next(r["tick"] for r in trace if r["kind"] == "monitor_preempt")
    # pybullet's own contact list: the first tick after the pre-emption's release with the wall touched again
    released = next(k for k in range(preempt + 1, len(touching)) if not touching[k - 1])
    again = next(k for k in range(released, len(touching)) if touching[k - 1])
    assert [r["tick"] for r in trace if r["kind"] == "monitor_abort"] == [again]
    assert result.outcome == "aborted" and "recovery 'back_off' aborted by monitor 'guard' (guard): contact " \
        "with wall" in result.reason
    assert result.result["monitors"]["guard"]["recovery"]["outcome"] == "halted"


@pytest.mark.parametrize("monitor,recoveries,expected", [
    ({"type": "guard", "sensor": "bump", "action": "stop"}, {},
     "monitors.guard.action: expected one of 'observe', 'abort', 'recover', got 'stop'"),
    ({"type": "guard", "sensor": "bump", "action": "recover"}, {},
     "monitors.guard.recovery: action 'recover' needs recovery = the name of a [recoveries.NAME] section"),
    ({"type": "guard", "sensor": "bump", "action": "recover", "recovery": "bakc_off"},
     {"back_off": {"type": "go_to_goal", "goal": [0, 0]}},
     "monitors.guard.recovery: unknown recovery 'bakc_off' (did you mean 'back_off'?); defined: back_off"),
    ({"type": "guard", "sensor": "nope", "action": "abort"}, {},
     "monitors.guard.sensor: 'nope' is not a contact or force_torque sensor; those: bump"),
    ({"type": "guard", "sensor": "bump"}, {"back_off": {"type": "go_to_goal"}}, "recoveries.back_off.goal: "),
])
def test_monitor_action_errors_are_one_line_with_the_key(tmp_path: Path, monitor: dict[str, Any],
                                                         recoveries: dict[str, Any], expected: str) -> None:
    from test_compose import _toml  # the suite's tiny TOML writer

    raw = copy.deepcopy(BOT)
    raw["monitors"] = {"guard": monitor}
    raw["recoveries"] = recoveries
    if not recoveries:
        del raw["recoveries"]
    path = tmp_path / "c.toml"
    path.write_text(_toml(raw))
    line = validate_error(path)
    assert expected in line and "\n" not in line.strip(), line


@pytest.mark.parametrize("behaviour,expected", [
    ({"type": "retry"}, "behaviour.child: a retry needs a child: one [behaviour.child] table, each with a type"),
    ({"type": "retry", "child": {"type": "record"}, "attempts": 0}, "behaviour.attempts: "),
    ({"type": "timeout", "child": {"type": "record"}}, "behaviour.seconds: "),
    ({"type": "parallel", "children": [{"type": "record"}]},
     "behaviour.children: a parallel needs children: 2 or more [[behaviour.children]] tables"),
    ({"type": "parallel", "success": "most", "children": [{"type": "record"}, {"type": "record", "name": "b"}]},
     "behaviour.success: "),
    ({"type": "fallback", "children": [{"type": "retry", "child": {"type": "go_to_gaol"}}]},
     "behaviour.children[0].child.type: unknown behaviour type 'go_to_gaol' (did you mean 'go_to_goal'?)"),
    ({"type": "sequence", "steps": [{"type": "timeout", "seconds": 1, "child": {"type": "go_to_goal", "goal": [1, 0],
                                                                               "speed": 2}}]},
     "behaviour.steps[0].child.speed: unknown key 'speed'"),
])
def test_composite_config_errors_are_one_line_with_the_nested_key(tmp_path: Path, behaviour: dict[str, Any],
                                                                  expected: str) -> None:
    from test_compose import _toml

    raw = copy.deepcopy(BOT)
    raw["behaviour"] = behaviour
    del raw["monitors"], raw["recoveries"]
    path = tmp_path / "c.toml"
    path.write_text(_toml(raw))
    line = validate_error(path)
    assert expected in line and "\n" not in line.strip(), line


TREE: dict[str, Any] = {  # every composite, nested, on real physics: out to the goal, then back home
    "type": "sequence",
    "steps": [
        {"type": "timeout", "name": "in_time", "seconds": 30.0, "child": {
            "type": "retry", "name": "twice", "attempts": 2, "child": {
                "type": "fallback", "name": "either", "children": [
                    {"type": "go_to_goal", "name": "hopeless", "goal": [1.0, 0.5], "timeout": 0.5},
                    {"type": "go_to_goal", "name": "out", "goal": [1.0, 0.5]}]}}},
        {"type": "parallel", "name": "home", "success": "all", "children": [
            {"type": "go_to_goal", "name": "back", "goal": [0.0, 0.0]},
            {"type": "record", "name": "log", "components": ["drive"], "duration": 1.0, "rate_hz": 10}]},
    ],
}


def test_nested_composites_on_real_physics_reach_the_goal_and_come_back() -> None:
    raw = copy.deepcopy(BOT)
    raw["sensors"] = {"scan": {"type": "lidar", "rays": 36, "rate_hz": 10}}
    raw["bodies"] = {"plane": raw["bodies"]["plane"]}
    raw["behaviour"] = TREE
    raw["world"]["max_time"] = 40.0
    del raw["monitors"], raw["recoveries"]
    with make_sim(raw) as sim:
        result = sim.run()
        x, y, _ = sim.readings["drive"].pose
        trace = sim.trace
    assert result.outcome == "succeeded", result.reason
    first, home = result.result["steps"]
    retry = first["result"]["children"][0]
    assert retry["outcome"] == "succeeded" and retry["reason"].startswith("attempt 1 of 2 succeeded: alternative 2")
    alternatives = retry["result"]["children"][0]["result"]["children"]
    assert [(a["name"], a["outcome"]) for a in alternatives] == [("hopeless", "failed"), ("out", "succeeded")]
    assert alternatives[0]["sim_time"] == pytest.approx(0.5, abs=0.06)  # its own timeout, from its own start
    assert home["outcome"] == "succeeded" and math.hypot(x, y) <= 0.2 + 0.02
    children = [(r["composite"], r["child"]) for r in trace if r["kind"] == "child_start"]
    assert ("either", "hopeless") in children and ("either", "out") in children and ("home", "log") in children


def test_graph_draws_a_nested_tree_and_a_monitor_with_its_recovery(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from test_compose import _toml

    raw = copy.deepcopy(BOT)
    raw["behaviour"] = TREE
    raw["sensors"]["scan"] = {"type": "lidar", "rays": 36}
    path = tmp_path / "tree.toml"
    path.write_text(_toml(raw))
    assert main(["graph", str(path)]) == 0
    out = capsys.readouterr().out
    for line in ('state "task: sequence of 2" as task {', 'state "1. in_time: timeout 30 s of 1" as task_1 {',
                 'state "1. twice: retry x2 of 1" as task_1_1 {', 'state "1. either: fallback of 2" as task_1_1_1 {',
                 'state "1. hopeless (go_to_goal)" as task_1_1_1_1 {', "task_1_1_1_1 --> task_1_1_1_2: failed",
                 "task_1_1_1_1 --> [*]: succeeded",  # the first alternative succeeded: the fallback ends
                 "task_1 --> [*]: failed or aborted",  # a step that does not succeed ends the sequence
                 "task_1_1_1 --> task_1_1_1: failed (a fresh attempt)",
                 'state "2. home: parallel success all, failure one of 2" as task_2 {',
                 'state "monitor guard (guard), action recover" as m_guard {',
                 'state "recovery back_off (go_to_goal)" as r_back_off {',
                 "m_guard --> r_back_off: failed or aborted: pre-empt the task"):
        assert line in out, line


def test_stop_on_stops_ik_arm_and_gripper_at_the_first_contact_with_no_monitor() -> None:
    raw = read_toml(CONFIGS / "contact_abort.toml")
    contact_tick, _ = _first_contact_tick(raw)
    del raw["monitors"]
    raw["actuators"]["arm"]["stop_on"] = "touch"
    raw["actuators"]["gripper"]["stop_on"] = "touch"
    with make_sim(raw, base_dir=CONFIGS) as sim:
        result = sim.run()
        stops = [r for r in sim.trace if r["kind"] == "protective_stop"]
        arm = sim.readings["arm"]
    # the arm's update() runs after the behaviour in the tick the sensor first sees the contact
    assert {(r["actuator"], r["tick"]) for r in stops} == {("arm", contact_tick), ("gripper", contact_tick)}
    assert arm.stopped and arm.reason.startswith("protective stop: contact with table (")
    # latched: pick_place sees its arm failed and gives up (it cannot move the arm again)
    assert result.outcome == "failed" and "arm failed in DESCEND: protective stop: contact with table" in result.reason


def test_a_guard_on_a_force_torque_sensor_trips_on_the_change_from_its_first_reading() -> None:
    from robokit.checks.scripted import ScriptedRun
    from robokit.msgs import Wrench

    run = ScriptedRun("guard", {"sensor": "wrist", "max_force": 15.0}, components={"wrist": Wrench})
    hanging = Wrench((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), "world")  # the hand's own weight: the baseline
    for fz in (10.0, 12.0, 24.0):  # |change| 0, 2, 14 N: below the limit
        run.step({"wrist": Wrench((0.0, 0.0, fz), (0.0, 0.0, 0.0), "world")} if fz != 10.0 else {"wrist": hanging})
        assert run.outcome is None
    run.step({"wrist": Wrench((0.0, 12.0, 20.0), (0.0, 0.0, 0.0), "world")})  # |(0, 12, 10)| = 15.6 N > 15
    assert run.outcome is not None and run.outcome.status == "aborted"
    assert run.outcome.reason == "force 15.6 N at world at t = 0.013 s (limit 15 N)"
    assert run.result() == {"peak_force": 15.62, "tripped_at": 3 / 240}
