"""Every composite against every combination of child outcomes, judged by the rule table of docs/behaviours.md.

Children are scripted: each instance ends after a generated number of its own steps with a generated outcome
(``succeeded``, ``failed``, ``aborted``) or never ends; a retry's attempts each take the next entry of the child's
plan. The expected outcome, the tick it comes, and every child's record (its outcome, or ``halted``, or ``not
started``) are worked out below by a plain reading of the docs' table ("Composites", section 9) and its shared
rules: a child that ends at tick k hands over at tick k + 1; a child stopped before its end is halted (its
``halt(t)`` runs) and never stepped again. Scripted children have no goal, so their judged outcome is the one they
claim.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import SimpleNamespace
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.checks.scripted import ScriptedRun
from robokit.components import Behaviour, GoalCheck
from robokit.core.composites import (
    Fallback,
    FallbackConfig,
    Member,
    Parallel,
    ParallelConfig,
    Retry,
    RetryConfig,
    Sequence,
    SequenceConfig,
    Timeout,
    TimeoutConfig,
)

DT = 1.0 / 240.0
HORIZON = 40  # ticks; every generated plan ends well within it, or never
ENDS = ("succeeded", "failed", "aborted")
PROPS = settings(max_examples=150, deadline=None, derandomize=True)


class Plan:
    """A child's script: per instance (a retry builds one per attempt) ``(outcome or None, steps before it)``."""

    def __init__(self, entries: list[tuple[str | None, int]]) -> None:
        self.entries = entries
        self.built = 0
        self.steps: list[int] = []  # steps taken, per instance
        self.halts: list[tuple[int, int]] = []  # (instance, tick) of each halt


class Scripted(Behaviour):
    """Ends on its own step number ``d + 1`` with the plan's outcome; commands ``motor_<name>`` every step."""

    def __init__(self, name: str, config: Plan) -> None:
        super().__init__(name, config)
        self.instance = config.built
        config.built += 1
        config.steps.append(0)
        self.outcome_, self.after = config.entries[min(self.instance, len(config.entries) - 1)]

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        plan = self.config
        plan.steps[self.instance] += 1
        if self.outcome_ is not None and plan.steps[self.instance] == self.after + 1:
            self.finish(self.outcome_, f"{self.name} {self.outcome_}")
        return {f"motor_{self.name}": self.instance}

    def halt(self, t: float) -> Mapping[str, Any]:
        self.config.halts.append((self.instance, round(t / DT)))
        return {f"motor_{self.name}": "stopped"}

    def result(self) -> dict[str, Any]:
        return {"instance": self.instance, "steps": self.config.steps[self.instance]}


def run_tree(composite: Any, plans: dict[str, Plan]) -> tuple[str | None, int | None, ScriptedRun]:
    composite.add_children([Member.of(Scripted(name, plan)) for name, plan in plans.items()])
    run = ScriptedRun(composite)
    run.sent = []  # type: ignore[attr-defined]  # the commands of every tick
    for k in range(HORIZON):
        run.sent.append(run.step({}))  # type: ignore[attr-defined]
        if run.outcome is not None:
            return run.outcome.status, k, run
    return None, None, run


def records(run: ScriptedRun, key: str) -> dict[str, str]:
    return {r["name"]: r["outcome"] for r in run.result()[key]}


def check_trace(run: ScriptedRun, composite: str, key: str, kind: str) -> None:
    """docs/behaviours.md: every start, end and halt is a trace record naming the composite and the child (a
    sequence writes step_start / step_end); each child's record has name, type, outcome, reason, started_at."""
    label, word = ("step", "step") if kind == "sequence" else ("child", "child")
    for r in run.result()[key]:
        i = int(r["name"][1:] or 0)  # its place among the children ("c<i>"); records come in the order they ended
        assert r["type"] == "Scripted" and set(r) >= {"name", "type", "outcome", "reason", "result"}
        starts = [x for x in run.trace if x["kind"] == f"{word}_start" and x[label] == r["name"]]
        ends = [x for x in run.trace if x["kind"] == f"{word}_end" and x[label] == r["name"]]
        halts = [x for x in run.trace if x["kind"] == "child_halt" and x["child"] == r["name"]]
        if r["outcome"] == "not started":
            assert not starts and not ends and not halts
            continue
        assert [(x["composite"], x["index"], x["type"]) for x in starts] == [(composite, i, "Scripted")]
        if r["outcome"] == "halted":
            assert not ends and [x["composite"] for x in halts] == [composite]
        elif r["outcome"] == "running":
            assert not ends and not halts
        else:
            assert [(x["composite"], x["index"], x["outcome"], x["reason"]) for x in ends] == [
                (composite, i, r["outcome"], r["reason"])]


child = st.tuples(st.sampled_from([*ENDS, None]), st.integers(0, 4))


# ------------------------------------------------------------------------------------------ ordered
def expect_ordered(kind: str, children: list[tuple[str | None, int]]) -> tuple[str | None, int | None, list[str]]:
    """sequence: in order; the first that does not succeed ends it with its outcome; succeeded when all did.
    fallback: in order; the first that succeeds ends it (succeeded); failed or aborted hands over; failed when
    all failed."""
    tick, seen = 0, []
    for outcome, d in children:
        if outcome is None:
            return None, None, [*seen, "running"] + ["not started"] * (len(children) - len(seen) - 1)
        end = tick + d
        seen.append(outcome)
        rest = ["not started"] * (len(children) - len(seen))
        if kind == "sequence" and outcome != "succeeded":
            return outcome, end, seen + rest
        if kind == "fallback" and outcome == "succeeded":
            return "succeeded", end, seen + rest
        tick = end + 1
    return ("succeeded" if kind == "sequence" else "failed"), tick - 1, seen


@PROPS
@given(st.sampled_from(["sequence", "fallback"]), st.lists(child, min_size=1, max_size=4))
def test_sequence_and_fallback_against_every_outcome_combination(kind: str, children: list) -> None:
    plans = {f"c{i}": Plan([c]) for i, c in enumerate(children)}
    composite = Sequence("seq", SequenceConfig()) if kind == "sequence" else Fallback("fb", FallbackConfig())
    outcome, tick, run = run_tree(composite, plans)
    want, want_tick, want_children = expect_ordered(kind, children)
    assert (outcome, tick) == (want, want_tick)
    got = records(run, "steps" if kind == "sequence" else "children")
    assert [got.get(n, "not started") for n in plans] == want_children
    assert all(not p.halts for p in plans.values())  # an ordered composite ends no child early
    check_trace(run, composite.name, "steps" if kind == "sequence" else "children", kind)
    if kind == "fallback" and outcome == "failed":  # every alternative failed or aborted: each one's reason named
        assert all(f"c{i} {o}" in run.outcome.reason for i, (o, _) in enumerate(children))  # type: ignore[union-attr]
    if kind == "sequence":
        assert run.result()["steps_completed"] == want_children.count("succeeded")
    start = 0  # each record: when the child started, how long it ran (sim s), and the child's own result
    for r, (_, d), plan in zip(run.result()["steps" if kind == "sequence" else "children"], children,
                               plans.values(), strict=True):
        if r["outcome"] == "not started":
            assert r["result"] == {}
            continue
        assert r["started_at"] == pytest.approx(start * DT, abs=2e-6)
        assert r["result"] == {"instance": 0, "steps": plan.steps[0]}
        if r["outcome"] != "running":
            assert r["sim_time"] == pytest.approx(d * DT, abs=2e-6)
        start += d + 1


# ------------------------------------------------------------------------------------------ retry
@PROPS
@given(st.lists(child, min_size=1, max_size=5), st.integers(1, 4))
def test_retry_against_every_sequence_of_attempt_outcomes(attempts_plan: list, attempts: int) -> None:
    """Runs the child until it succeeds, at most ``attempts`` times, each a fresh instance; its outcome is the last
    attempt's; the next attempt starts the tick after one ends."""
    plan = Plan(attempts_plan)
    outcome, tick, run = run_tree(Retry("retry", RetryConfig(attempts=attempts)), {"c": plan})
    t, want, want_tick, made = 0, None, None, 0
    for a in range(attempts):
        o, d = attempts_plan[min(a, len(attempts_plan) - 1)]
        made += 1
        if o is None:
            break
        if o == "succeeded" or a == attempts - 1:
            want, want_tick = o, t + d
            break
        t += d + 1
    assert (outcome, tick) == (want, want_tick)
    assert plan.built == made  # one fresh instance per attempt, none more
    if outcome is not None:
        result = run.result()
        assert result["attempts"] == made
        # every attempt keeps its own record and result
        assert [r["result"] for r in result["children"]] == [{"instance": a, "steps": plan.steps[a]}
                                                              for a in range(made)]
        starts = [(x["composite"], x["index"]) for x in run.trace if x["kind"] == "child_start"]
        ends = [(x["index"], x["outcome"]) for x in run.trace if x["kind"] == "child_end"]
        assert starts == [("retry", a) for a in range(made)]  # each attempt's start and end, numbered
        assert ends == [(a, r["outcome"]) for a, r in enumerate(result["children"])]


# ------------------------------------------------------------------------------------------ timeout
@PROPS
@given(child, st.integers(0, 6), st.sampled_from([0.0, 0.5]))
def test_timeout_against_every_child_outcome_and_length(c: tuple, limit_ticks: int, extra: float) -> None:
    """Runs the child; when it has not ended ``seconds`` after its start, halts it and fails (checked before the
    child's step of that tick: the first step where *more* than ``seconds`` passed); a child that ends in time
    gives its own outcome."""
    plan = Plan([c])
    seconds = (limit_ticks + extra) * DT or 0.5 * DT  # on a tick (exactly k ticks) or between two
    outcome, tick, run = run_tree(Timeout("to", TimeoutConfig(seconds=seconds)), {"c": plan})
    check_trace(run, "to", "children", "timeout")
    o, d = c
    first_late = limit_ticks + 1  # the first tick whose elapsed time exceeds the limit
    if o is not None and d < first_late:
        assert (outcome, tick) == (o, d) and not plan.halts
    else:
        assert (outcome, tick) == ("failed", first_late)
        assert plan.halts == [(0, first_late)] and plan.steps == [first_late]  # halted, never stepped again
        assert run.sent[-1] == {"motor_c": "stopped"}  # type: ignore[attr-defined]  # its halt's commands go out
        record = run.result()["children"][0]
        assert record["outcome"] == "halted" and record["reason"]
        assert record["sim_time"] == pytest.approx(first_late * DT, abs=2e-6)


# ------------------------------------------------------------------------------------------ parallel
def expect_parallel(children: list[tuple[str | None, int]], success: str, failure: str
                    ) -> tuple[str | None, int | None, list[str]]:
    """Every child stepped each tick from tick 0; success "all"/"one", failure "one"/"all" decide (an aborted child
    counts as failed); if every child ended and no policy was met it fails; the children still running are halted."""
    n = len(children)
    for k in range(HORIZON):
        ended = [o if (o is not None and d <= k) else None for o, d in children]
        won = [o for o in ended if o == "succeeded"]
        lost = [o for o in ended if o in ("failed", "aborted")]
        decided = None
        if lost and (failure == "one" or len(lost) == n):
            decided = "failed"
        elif won and (success == "one" or len(won) == n):
            decided = "succeeded"
        elif len(won) + len(lost) == n:
            decided = "failed"
        if decided is not None:
            return decided, k, [o if o is not None else "halted" for o in ended]
    return None, None, ["running" if o is None else o for o, _ in children]


@PROPS
@given(st.lists(child, min_size=2, max_size=4), st.sampled_from(["all", "one"]), st.sampled_from(["one", "all"]))
def test_parallel_against_every_outcome_combination_and_policy(children: list, success: str, failure: str) -> None:
    plans = {f"c{i}": Plan([c]) for i, c in enumerate(children)}
    outcome, tick, run = run_tree(Parallel("par", ParallelConfig(success=success, failure=failure)), plans)
    want, want_tick, want_children = expect_parallel(children, success, failure)
    assert (outcome, tick) == (want, want_tick)
    got = records(run, "children")
    assert [got.get(n, "running") for n in plans] == want_children
    check_trace(run, "par", "children", "parallel")
    full = {r["name"]: r for r in run.result()["children"]}
    for name, plan in plans.items():  # a halted child: halted in the deciding tick, never stepped again
        if got.get(name) == "halted":
            assert plan.halts == [(0, tick)] and plan.steps == [tick + 1]
            # its halt's stop command replaces the command its step sent in that tick
            assert run.sent[-1][f"motor_{name}"] == "stopped"  # type: ignore[attr-defined]
            assert full[name]["reason"] and full[name]["sim_time"] == pytest.approx(tick * DT, abs=2e-6)
        else:
            assert not plan.halts
            if plan.steps and want is not None and plan.steps[0] == tick + 1:  # stepped in the deciding tick
                assert run.sent[-1][f"motor_{name}"] == 0  # type: ignore[attr-defined]


# ------------------------------------------------------------------------------------------ goals
class Goaled(Scripted):
    """A scripted child that states a goal: met or not when it ends, and met or not when asked again later."""

    def __init__(self, name: str, config: Plan) -> None:
        super().__init__(name, config)
        self.at_end, self.later = config.goals  # type: ignore[attr-defined]
        self.asked = 0

    def check_goal(self, world: Any) -> GoalCheck:
        assert world is not None  # judged on the run's world
        self.asked += 1
        met = self.at_end if self.asked == 1 else self.later
        return GoalCheck(met, f"{self.name} {'met' if met else 'not met'}")


goal_child = st.tuples(st.sampled_from([*ENDS, None]), st.integers(0, 3), st.sampled_from([None, True, False]),
                       st.booleans(), st.booleans())


def judged(claimed: str | None, goal: bool | None) -> str | None:
    """docs/behaviours.md, "When a goal is checked": a child that ended succeeded or failed is what the world says
    (met: succeeded, not met: failed); aborted stands; a child without a goal keeps its claim."""
    if claimed is None or goal is None or claimed == "aborted":
        return claimed
    return "succeeded" if goal else "failed"


@PROPS
@given(st.sampled_from(["sequence", "fallback", "parallel"]), st.lists(goal_child, min_size=2, max_size=4))
def test_composites_go_by_each_childs_goal_judged_when_it_ends(kind: str, children: list) -> None:
    plans = {}
    members = []
    for i, (claimed, d, goal, later, must_last) in enumerate(children):
        plan = Plan([(claimed, d)])
        plan.goals = (goal, later)  # type: ignore[attr-defined]
        plans[f"c{i}"] = plan
        child = Goaled(f"c{i}", plan) if goal is not None else Scripted(f"c{i}", plan)
        members.append(Member(f"c{i}", "Scripted", child, 1, "<scripted>", SimpleNamespace(must_last=must_last)))
    composite = {"sequence": lambda: Sequence("seq", SequenceConfig()),
                 "fallback": lambda: Fallback("fb", FallbackConfig()),
                 "parallel": lambda: Parallel("par", ParallelConfig())}[kind]()
    composite.add_children(members)
    run = ScriptedRun(composite)
    tick = None
    for k in range(HORIZON):
        run.step({})
        if run.outcome is not None:
            tick = k
            break
    as_judged = [(judged(c, g), d) for c, d, g, _, _ in children]
    if kind == "parallel":
        want, want_tick, want_children = expect_parallel(as_judged, "all", "one")
    else:
        want, want_tick, want_children = expect_ordered(kind, as_judged)
    assert (run.outcome.status if run.outcome else None, tick) == (want, want_tick)
    got = records(run, "steps" if kind == "sequence" else "children")
    assert [got.get(n, "not started" if kind != "parallel" else "running") for n in plans] == want_children
    # each judged child's record holds its goal, and what it claimed where the world disagreed; a goal trace each
    full = {r["name"]: r for r in run.result()["steps" if kind == "sequence" else "children"]}
    goals = [r for r in run.trace if r["kind"] == "goal"]
    ended = [i for i, (_, _, g, _, _) in enumerate(children)  # stated a goal and ended (not halted)
             if g is not None and full[f"c{i}"].get("sim_time") is not None and full[f"c{i}"]["outcome"] != "halted"]
    assert sorted((r["composite"], r["child"], r["met"], r["reason"]) for r in goals) == sorted(
        (composite.name, f"c{i}", children[i][2], f"c{i} {'met' if children[i][2] else 'not met'}") for i in ended)
    for i, (claimed, _, goal, _, _) in enumerate(children):
        record = full[f"c{i}"]
        if i in ended:
            assert record["goal"]["met"] == goal and record["goal"]["reason"] == f"c{i} {'met' if goal else 'not met'}"
        else:
            assert "goal" not in record
        if i in ended and judged(claimed, goal) != claimed:
            assert record["claimed"]["outcome"] == claimed and record["claimed"]["reason"] == f"c{i} {claimed}"
            word = "goal met" if goal else "goal not met"  # the world's word first, then what the child said
            assert record["reason"].startswith(f"{word}: c{i}") and f"c{i} reported {claimed}" in record["reason"]
        else:
            assert "claimed" not in record
    # the run's final verdict: only a composite that succeeded is asked again, about what must last
    verdict = composite.check_goal(run.world)
    if want != "succeeded":
        assert verdict is None
        return
    succeeded = [i for i, o in enumerate(want_children) if o == "succeeded"]
    final = succeeded[-1:] if kind == "sequence" else succeeded  # a sequence: its last step
    final = sorted(set(final) | {i for i in succeeded if children[i][4]})  # and every must_last child
    asked = [i for i in final if children[i][2] is not None]
    if not asked:
        assert verdict is None
    else:
        assert verdict is not None and verdict.met == all(children[i][3] for i in asked)
        key = "steps" if kind == "sequence" else "children"
        assert {n: (v["met"], v["reason"]) for n, v in verdict.details[key].items()} == {
            f"c{i}": (children[i][3], f"c{i} {'met' if children[i][3] else 'not met'}") for i in asked}
        missed = {f"c{i}: c{i} not met" for i in asked if not children[i][3]}  # the misses, or else every goal
        assert set(verdict.reason.split("; ")) == (missed or {f"c{i}: c{i} met" for i in asked})


# ------------------------------------------------------------------------------------------ a child that raises
class Raising(Scripted):
    """Never ends; raises in its step number ``after + 1`` (plan ``mode`` "raise-step") or in its halt."""

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        plan = self.config
        if plan.mode == "raise-step" and plan.steps[self.instance] == self.after:
            raise ValueError("a bug in the child")
        return super().step(readings, t)

    def halt(self, t: float) -> Mapping[str, Any]:
        if self.config.mode == "raise-halt":
            raise ValueError("a bug in the child's halt")
        return super().halt(t)


ROLES = {"sequence": "sequence step", "fallback": "fallback child", "retry": "retry child",
         "timeout": "timeout child", "parallel": "parallel child"}


@PROPS
@given(st.sampled_from(list(ROLES)), st.integers(1, 4), st.sampled_from(["raise-step", "raise-halt"]))
def test_a_child_that_raises_is_named_with_its_role_and_what_it_was_doing(kind: str, after: int, how: str) -> None:
    """A child's exception becomes one error naming the child, its role in the composite and the call (docs:
    errors for people; the traceback is the plugin's)."""
    from robokit.errors import PluginError

    if how == "raise-halt" and kind not in ("timeout", "parallel"):
        how = "raise-step"  # only a timeout or a parallel decides while a child runs
    bad = Plan([(None, after)])
    bad.mode = how  # type: ignore[attr-defined]
    halting = how == "raise-halt"  # the composite decides at tick `after` (halting the child), or never
    other = Plan([("failed", after) if halting else (None, 0)])  # a parallel sibling (failure "one")
    composite = {"sequence": lambda: Sequence("c", SequenceConfig()),
                 "fallback": lambda: Fallback("c", FallbackConfig()),
                 "retry": lambda: Retry("c", RetryConfig(attempts=2)),
                 "timeout": lambda: Timeout("c", TimeoutConfig(seconds=(after - 0.5 if halting else 100) * DT)),
                 "parallel": lambda: Parallel("c", ParallelConfig())}[kind]()
    members = [Member.of(Raising("bad", bad))] + ([Member.of(Scripted("other", other))] if kind == "parallel" else [])
    composite.add_children(members)
    run = ScriptedRun(composite)
    with pytest.raises(PluginError) as err:
        for _ in range(HORIZON):
            run.step({})
    text = str(err.value)
    assert f"{ROLES[kind]} 'bad'" in text
    assert ("during halt" if how == "raise-halt" else "during step") in text and "a bug in the child" in text


class NoHalt(Behaviour):
    """A child without ``halt`` (it is optional): never ends."""

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        return {f"motor_{self.name}": 1}


@pytest.mark.parametrize("kind", ["parallel", "timeout"])
def test_a_child_without_halt_is_halted_quietly(kind: str) -> None:
    """docs/behaviours.md: a halted child's *optional* ``halt(t)`` runs; a child without one is just booked halted."""
    composite = Parallel("c", ParallelConfig()) if kind == "parallel" else Timeout("c", TimeoutConfig(seconds=DT))
    members = [Member.of(NoHalt("quiet", None))]
    if kind == "parallel":
        members.append(Member.of(Scripted("other", Plan([("failed", 1)]))))
    composite.add_children(members)
    run = ScriptedRun(composite)
    for _ in range(5):
        run.step({})
    assert run.outcome is not None and run.outcome.status == "failed"
    assert {r["name"]: r["outcome"] for r in run.result()["children"]}["quiet"] == "halted"
