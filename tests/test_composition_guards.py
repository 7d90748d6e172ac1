"""Guards keep guarding: a wrist force guard that pre-empts a task into a recovery keeps watching the recovery; the
recovery repeating the task's mistake (the fingers driven into the table) ends the run ``aborted`` with a
protective stop in the tick the force crosses the limit again. Monitors declared after the guard see that tick.

The oracle is the wrist sensor's reading, read by the test every tick (the force's change from the first reading,
as the guard measures it), and the rule worked out by hand from it.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

from robokit.config import read_toml
from robokit.testing import make_sim

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
LIMIT = 40.0
"""N: the wrist guard's limit."""


def wrist_guarded(watch: bool = True) -> dict[str, Any]:
    """configs/contact_abort.toml (a grasp 6 cm too low) with a 40 N wrist guard that pre-empts the task into a
    recovery making the same mistake, and a recorder declared after the guard."""
    raw = read_toml(CONFIGS / "contact_abort.toml")
    guard: dict[str, Any] = {"type": "guard", "sensor": "wrist", "max_force": LIMIT, "action": "recover",
                             "recovery": "again"}
    if not watch:
        guard["watch_recovery"] = False
    raw["monitors"] = {"guard": guard, "log": {"type": "record", "components": ["wrist"], "duration": 0}}
    raw["recoveries"] = {"again": copy.deepcopy(raw["behaviour"])}
    return raw


def run_and_read(raw: dict[str, Any], after: int = 240) -> tuple[Any, list[float], list[dict[str, Any]]]:
    """Run to the end, then ``after`` ticks more; the wrist force (N, change from the first reading) the loop read
    in each tick (``forces[k]``: tick k's reading, as every behaviour saw it)."""
    with make_sim(raw, base_dir=CONFIGS) as sim:
        forces: list[float] = []
        first = None
        while sim.behaviour.outcome is None and sim.world.tick < 2400:
            sim.step()
            first = first or sim.readings["wrist"].force
            forces.append(math.dist(sim.readings["wrist"].force, first))
        outcome = sim.behaviour.outcome
        for _ in range(after):
            sim.step()
            forces.append(math.dist(sim.readings["wrist"].force, first))
        return outcome, forces, list(sim.trace)


def test_a_recovery_that_trips_the_same_guard_is_stopped_in_that_tick() -> None:
    outcome, forces, trace = run_and_read(wrist_guarded())
    preempt = next(r["tick"] for r in trace if r["kind"] == "monitor_preempt")
    assert forces[preempt] > LIMIT and max(forces[:preempt]) <= LIMIT  # the task tripped it
    # the rule by hand: after the pre-emption, until the force is back within the limit the guard allows no more
    # than the force that tripped it plus the limit; then it re-arms and trips at the first tick above the limit
    released = next(k for k in range(preempt + 1, len(forces)) if forces[k] <= LIMIT)
    worse = [k for k in range(preempt + 1, released) if forces[k] > forces[preempt] + LIMIT]
    again = worse[0] if worse else next(k for k in range(released, len(forces)) if forces[k] > LIMIT)
    aborts = [r for r in trace if r["kind"] == "monitor_abort"]
    assert [r["tick"] for r in aborts] == [again] and aborts[0]["recovery"] == "again"
    stops = {(r["tick"], r["actuator"]) for r in trace if r["kind"] == "protective_stop"}
    assert stops == {(preempt, "arm"), (preempt, "gripper"), (again, "arm"), (again, "gripper")}
    assert outcome.status == "aborted" and "recovery 'again' aborted by monitor 'guard' (guard)" in outcome.reason
    # the recorder, declared after the guard, recorded the wrist in both trip ticks
    recorded = {r["tick"] for r in trace if r["kind"] == "reading" and r["source"] == "log"}
    assert {preempt, again} <= recorded
    # the force stays below what tripped the guard first, in the recovery and for a second after it was stopped
    assert max(forces[released:]) < forces[preempt]


def test_without_the_watch_the_same_recovery_presses_on() -> None:
    outcome, forces, trace = run_and_read(wrist_guarded(watch=False), after=0)
    preempt = next(r["tick"] for r in trace if r["kind"] == "monitor_preempt")
    assert not [r for r in trace if r["kind"] == "monitor_abort"]
    assert outcome.status == "failed"  # the recovery's own failure, seconds later
    assert max(forces[preempt + 1:]) > 3 * forces[preempt]  # far beyond the first trip: what the watch prevents


def docs_block(marker: str) -> str:
    """The ```toml block of docs/behaviours.md holding ``marker``."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "behaviours.md").read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```toml\n")[1:]]
    return next(b for b in blocks if marker in b)


def test_the_docs_worked_tree_with_its_guard_runs_without_tripping_on_the_floor() -> None:
    import tomllib

    raw = tomllib.loads(docs_block('name = "in_time"'))
    raw.update({"world": {"max_time": 40.0, "seed": 2},
                "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}},
                "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
                "actuators": {"drive": {"type": "diff_drive", "rate_hz": 60}}})
    raw["sensors"]["scan"] = {"type": "lidar", "rays": 36, "rate_hz": 10}
    with make_sim(raw) as sim:
        result = sim.run()
        x, y, _ = sim.readings["drive"].pose
        wheels_on_floor = sim.world.contacts(sim.world.body("robot"), sim.world.body("plane"))
    assert wheels_on_floor  # the floor is touched all along: ignored, not absent
    assert result.outcome == "succeeded", result.reason
    assert result.result["monitors"]["guard"]["outcome"] == "running"
    assert math.hypot(x, y) <= 0.2 + 0.02  # home (go_to_goal's default tolerance)


def test_a_contact_sensor_refuses_ignore_with_other_and_an_unknown_body(tmp_path: Path) -> None:
    from test_compose import _toml

    from robokit.testing import validate_error

    base: dict[str, Any] = {"world": {"max_time": 0.1},
                            "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                                       "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1,
                                               "position": [0, 0, 0.05]}}}
    for sensor, expected in (
            ({"other": "plane", "ignore": ["plane"]}, "sensors.touch.ignore: 'ignore' is for contacts with anything"),
            ({"ignore": ["plnae"]}, "sensors.touch.ignore[0]: ")):
        raw = {**base, "sensors": {"touch": {"type": "contact", "body": "box", **sensor}}}
        path = tmp_path / "c.toml"
        path.write_text(_toml(raw))
        assert expected in validate_error(path)
