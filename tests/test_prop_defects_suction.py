"""``suction``'s ``reset()`` gives a fresh build's start state, on both engines, after generated histories.

The contract every resettable actuator keeps (docs/gym.md "Tasks are plugins", docs/arm.md "Suction"): after the
world's snapshot is restored and the components reset (as robokit.gym does between episodes), the readings and the
world equal a fresh build's, and so do the next ticks. Each example runs a generated history on one build (the cup
turned on and off, pressed onto the cube so that it holds it, carried up and sideways, a protective stop), restores
and resets, and compares it with a second, fresh build: every field of the cup's reading and the full state of
every body (poses, velocities, links, dynamics, attachments, the engine's constraints), bit for bit, then after
ticks with no command, then after a ``close`` that picks the cube up again.
"""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from test_prop_reset import differences, world_state

from robokit.msgs.arm import GripperCommand
from robokit.testing import PLANE, make_sim

ENGINES = ["pybullet", "mujoco"]
SIZE = 0.05
CUP_H = 0.02
SCENE = {"bodies": {"plane": PLANE,
                    "cube": {"shape": "box", "size": [SIZE] * 3, "mass": 0.1, "position": [0.0, 0.0, SIZE / 2]},
                    "cup": {"shape": "cylinder", "radius": 0.012, "height": CUP_H, "mass": 0,
                            "position": [0.0, 0.0, SIZE - 0.0005 + CUP_H / 2]}},
         "actuators": {"cup": {"type": "suction", "body": "cup", "max_force": 30.0}}}


def state(sim: Any) -> tuple:
    """The world's full state and the cup's reading. An attachment's id and name are left out: both engines count
    them up for the world's life (a second grasp is attachment 2), the rest of it is compared."""
    out = world_state(sim.world)
    constraints = out["engine"]["constraints"]
    if sim.world.engine == "pybullet":
        out["engine"]["constraints"] = [c[1:] for c in constraints]
    else:
        constraints[0] = [held[:2] for _, held in constraints[0]]
    return out, sim.readings["cup"]


def same(used: Any, fresh: Any, when: str) -> None:
    a, b = state(used), state(fresh)
    assert differences(a[0], b[0]) == [], when
    assert a[1] == b[1], when


steps = st.lists(st.tuples(st.sampled_from(["close", "open", "stop", "lift", "slide"]), st.integers(1, 30)),
                 min_size=1, max_size=6)


SETTINGS = {"deadline": None, "derandomize": True, "phases": [Phase.explicit, Phase.generate],
            "suppress_health_check": [HealthCheck.function_scoped_fixture, HealthCheck.too_slow]}


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=2, **SETTINGS)
@given(history=steps)
def test_a_reset_suction_cup_is_a_fresh_one(history: list, engine: str) -> None:
    reset_is_fresh(history, engine)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=25, **SETTINGS)
@given(history=steps)
def test_a_reset_suction_cup_is_a_fresh_one_after_many_histories(history: list, engine: str) -> None:
    reset_is_fresh(history, engine)


def reset_is_fresh(history: list, engine: str) -> None:
    overrides = {"world.engine": engine}
    with make_sim(SCENE, overrides=overrides) as used, make_sim(SCENE, overrides=overrides) as fresh:
        snap = used.world.snapshot()
        cup = used.components["cup"]
        w = used.world
        for what, ticks in [("close", 5), *history]:  # the cup always holds the cube at some point
            if what in ("close", "open"):
                cup.command(GripperCommand(what))
            elif what == "stop":
                cup.protective_stop("a test")
            else:
                (x, y, z), q = w.pose("cup")
                w.set_pose("cup", [x, y, z + 0.02] if what == "lift" else [x + 0.02, y, z], q)
            used.step(ticks)
        used.world.restore(snap)
        for comp in used.components.values():
            if hasattr(comp, "reset"):  # as robokit.gym resets them
                comp.reset(None)
        used.step(1)
        fresh.step(1)
        same(used, fresh, "after the reset")
        used.step(20)
        fresh.step(20)
        same(used, fresh, "20 ticks on")
        for sim in (used, fresh):
            sim.components["cup"].command(GripperCommand("close"))
            sim.step(10)
        same(used, fresh, "after a close")
        assert used.readings["cup"].holding and used.readings["cup"].held == "cube"
