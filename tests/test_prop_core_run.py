"""How a run ends, over every combination of what can end it, judged by docs/outcomes.md's rules.

A scripted behaviour ends on a generated step with a generated claim (``succeeded``, ``failed``, ``aborted``) or
never, may be open-ended, states a goal the test decides (none, met, not met), and may have the run interrupted on a
generated step (the run's own ``interrupt``, as Ctrl-C does) -- also on the very step it ends. ``max_time`` is
generated too, among them times that are not a whole number of ticks in floating point (0.015 s at 240 Hz is
3.5999... ticks before rounding).

Expected, written plainly from the docs: the run stops after the tick the behaviour ends or is interrupted in, or
after ``round(max_time / time_step)`` ticks; a behaviour that ended gives its claim, judged by its goal (met turns a
``failed`` claim into ``succeeded``, not met turns a claim of ``succeeded``/``failed`` into ``failed``, an ``aborted``
claim stays aborted with the goal's reason added when not met); an interrupt is ``aborted`` naming it, ``interrupted``
true only when the behaviour had not ended; ``max_time`` reached is ``aborted`` (``succeeded`` for an open-ended
behaviour), the goal's reason added when not met; ticks and sim time count the ticks run.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit import hookimpl
from robokit.components import Behaviour, GoalCheck
from robokit.testing import make_sim

DT = 1.0 / 240.0


class Script(Behaviour):
    """Ends on its step ``end`` (1-based; None: never) with ``claim``; interrupts the run on its step ``stop``."""

    open_ended = False

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.steps = 0
        self.plan: dict[str, Any] = {}
        self.interrupt: Any = None

    def step(self, readings: Mapping[str, Any], t: float) -> Any:
        self.steps += 1
        if self.steps == self.plan["stop"]:
            self.interrupt("SIGINT")
        if self.steps == self.plan["end"]:
            self.finish(self.plan["claim"], "as scripted")
        return None

    def check_goal(self, world: Any) -> GoalCheck | None:
        met = self.plan["goal"]
        return None if met is None else GoalCheck(met, "the scripted goal", {})


class OpenScript(Script):
    open_ended = True


class ScriptPlugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("script", Script, None)
        register("open_script", OpenScript, None)


def expected(plan: dict[str, Any], open_ended: bool, limit: float) -> tuple[str, str, int, bool]:
    max_ticks = round(limit / DT)
    end, stop = plan["end"], plan["stop"]
    ticks = min(t for t in (end, stop, max_ticks) if t is not None)
    ended = end is not None and end == ticks
    interrupted = stop is not None and stop == ticks
    if ended:
        outcome, reason = plan["claim"], "as scripted"
    elif interrupted:
        outcome, reason = "aborted", f"interrupted by SIGINT at t = {ticks * DT:.3f} s"
    elif open_ended:
        outcome, reason = "succeeded", f"open-ended behaviour ran for max_time {limit:g} s"
    else:
        outcome, reason = "aborted", f"max_time {limit:g} s reached before the behaviour finished"
    goal = plan["goal"]  # the world's verdict on a run that ended succeeded or failed; noted on any other
    if goal is not None and outcome not in ("succeeded", "failed"):
        reason += "" if goal else "; goal not met: the scripted goal"
    elif goal is True and outcome == "failed":
        outcome, reason = "succeeded", f"goal met: the scripted goal (the behaviour reported failed: {reason})"
    elif goal is False:
        outcome, reason = "failed", f"goal not met: the scripted goal (the behaviour reported {outcome}: {reason})"
    return outcome, reason, ticks, interrupted and not ended


step_no = st.one_of(st.none(), st.integers(1, 30))


@pytest.mark.slow  # a world built per example: ~70 ms each
@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.fixed_dictionaries({"end": step_no, "stop": step_no, "claim": st.sampled_from(["succeeded", "failed",
                                                                                      "aborted"]),
                              "goal": st.sampled_from([None, True, False])}),
       st.booleans(), st.sampled_from([0.015, 0.02, 0.045, 0.05, 0.1, 0.125]))
def test_how_a_run_ends(plan: dict[str, Any], open_ended: bool, limit: float) -> None:
    check_run(plan, open_ended, limit)


# the rarer endings, one world each, in the default tier
@pytest.mark.parametrize("plan,open_ended,limit", [
    ({"end": 3, "stop": None, "claim": "aborted", "goal": True}, False, 0.1),  # aborted, goal met: nothing added
    ({"end": None, "stop": None, "claim": "failed", "goal": None}, False, 0.015),  # 3.5999... ticks: 4
    ({"end": None, "stop": None, "claim": "failed", "goal": None}, True, 0.02),  # open-ended at max_time
    ({"end": 5, "stop": 5, "claim": "succeeded", "goal": None}, False, 0.1),  # interrupted as it ended
    ({"end": None, "stop": 2, "claim": "failed", "goal": False}, False, 0.1),  # interrupted, goal not met
])
def test_how_a_run_ends_rare_cases(plan: dict[str, Any], open_ended: bool, limit: float) -> None:
    check_run(plan, open_ended, limit)


def check_run(plan: dict[str, Any], open_ended: bool, limit: float) -> None:
    config = {"behaviour": {"type": "open_script" if open_ended else "script"}}
    with make_sim(config, extra_plugins=(ScriptPlugin(),)) as sim:
        assert sim.world.time_step == DT
        sim.behaviour.plan = plan
        sim.behaviour.interrupt = sim.interrupt
        result = sim.run(max_time=limit)
    outcome, reason, ticks, interrupted = expected(plan, open_ended, limit)
    assert (result.outcome, result.reason) == (outcome, reason), (plan, open_ended, limit)
    assert (result.ticks, result.sim_time, result.interrupted) == (ticks, round(ticks * DT, 6), interrupted)
    if plan["goal"] is not None:
        assert result.result["goal"]["met"] is plan["goal"]
