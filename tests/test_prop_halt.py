"""What a behaviour leaves its actuators doing when something else stops it.

docs/behaviours.md: a child stopped before its end is **halted** -- its ``halt(t)`` runs and returns the commands
that stop what it started -- and is never stepped again. Here each built-in behaviour that commands actuators runs
as the child of a ``timeout`` (a generated number of sim seconds) in a ``fallback`` whose next alternative is a
``record`` that commands nothing for a second: whatever the halted behaviour last sent must not go on. The oracle is
the world: the mobile base's speed, the arm's joint angles, read in the test.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomllib
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.testing import make_sim

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
# behaviour type -> (shipped config, a cheap sensor for the record step, what to watch)
CASES = {
    "go_to_goal": ("go_to_goal.toml", "scan", "base"),
    "patrol": ("patrol.toml", "bump", "base"),
    "pick_place": ("pick_place.toml", "poses", "arm"),
    "sort": ("sort_robot.toml", "truth", "arm"),
    "drive_teleop": ("drive_teleop.toml", "keys", "base"),  # halted while its script holds the up arrow
}


def halted_config(name: str, seconds: float) -> dict[str, Any]:
    file, sensor, _ = CASES[name]
    cfg = tomllib.loads((CONFIGS / file).read_text(encoding="utf-8"))
    task = cfg.pop("behaviour")
    assert task["type"] == name
    cfg["world"] = {**cfg.get("world", {}), "max_time": 60.0}
    cfg.pop("monitors", None)
    cfg["behaviour"] = {"type": "fallback", "children": [
        {"type": "timeout", "seconds": seconds, "child": task},
        {"type": "record", "duration": 1.0, "components": [sensor]}]}
    return cfg


def moving_parts(sim: Any, what: str) -> Any:
    """Base speed (m/s) of the mobile robot, or the arm's joint angles (rad)."""
    w = sim.world
    if what == "base":
        lin, _ = w.velocity(sim.components["drive"].body)
        return math.hypot(lin[0], lin[1])
    arm = sim.components["arm"].body
    joints = [j.index for j in w.joints(arm) if j.movable]
    return np.array([s[0] for s in w.joint_states(arm, joints)])


def tool(sim: Any) -> np.ndarray:
    """The arm's tool frame (its ``ee_link``) in the world."""
    w, arm = sim.world, sim.components["arm"]
    link = next(j.index for j in w.joints(arm.body) if j.child_link == arm.config.ee_link)
    return np.array(w.pose(arm.body, link)[0])


@pytest.mark.parametrize("name", [
    "go_to_goal", "patrol", "drive_teleop",
    pytest.param("pick_place", marks=pytest.mark.slow),  # the Panda: ~10 s of CPU a case on two loaded cores
    pytest.param("sort", marks=pytest.mark.slow)])
@settings(max_examples=2, deadline=None, derandomize=True)
@given(st.floats(0.4, 2.5))
def test_a_halted_behaviour_leaves_its_actuators_stopped(name: str, seconds: float) -> None:
    what = CASES[name][2]
    with make_sim(halted_config(name, seconds), base_dir=CONFIGS) as sim:
        hz = sim.world.physics_hz
        sim.step(round(seconds * hz))
        while not [r for r in sim.trace if r["kind"] == "child_halt"] and sim.world.tick < (seconds + 0.2) * hz:
            sim.step(1)
        assert [r for r in sim.trace if r["kind"] == "child_halt"], "the timeout halted its child"
        tool_at_halt = tool(sim) if what == "arm" else None
        sim.step(round(0.5 * hz))  # half a second to come to rest
        before = moving_parts(sim, what)
        sim.step(round(0.4 * hz))  # the record step runs; nothing commands the actuators
        after = moving_parts(sim, what)
        tool_after = tool(sim) if what == "arm" else None
        assert sim.outcome is None or sim.outcome.status != "error"
    if what == "base":
        assert before < 0.03 and after < 0.03, f"{name}: the base still moves at {after:.3f} m/s after its halt"
    else:
        assert np.max(np.abs(after - before)) < 0.01, f"{name}: the arm still moves after its halt"
        # the arm holds where it was halted (a stopping distance), not where its last move was going
        moved = float(np.linalg.norm(tool_after - tool_at_halt))
        assert moved < 0.02, f"{name}: the tool went on {moved:.3f} m after its halt"
