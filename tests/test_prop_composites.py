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

import re
from collections.abc import Mapping
from types import SimpleNamespace
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit import hookimpl
from robokit.checks.scripted import ScriptedRun
from robokit.components import Behaviour, GoalCheck
from robokit.config.sections import Section, setting
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
PROPS = settings(max_examples=100, deadline=None, derandomize=True)


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


def end_tick(run: ScriptedRun) -> int | None:
    """Step ``run`` until it ends (at most ``HORIZON`` ticks): the tick it ended at, None if it did not."""
    for k in range(HORIZON):
        run.step({})
        if run.outcome is not None:
            return k
    return None


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
            assert not starts and not ends and not halts and r["reason"] == ""
            continue
        assert [(x["composite"], x["index"], x["type"]) for x in starts] == [(composite, i, "Scripted")]
        if r["outcome"] == "halted":
            assert not ends and [(x["composite"], x["reason"]) for x in halts] == [(composite, r["reason"])]
        elif r["outcome"] == "running":
            assert not ends and not halts and r["reason"] == ""
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
    assert composite.name == ("seq" if kind == "sequence" else "fb")
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
    retry = Retry("retry", RetryConfig(attempts=attempts))
    retry.add_children([Member.of(Scripted("c", plan))])
    run = ScriptedRun(retry)
    outcome = tick = None
    for k in range(HORIZON):
        run.step({})
        # read at any tick (between two attempts too), each attempt's record keeps that attempt's own result
        assert [(r["name"], r["type"], r["result"]) for r in run.result()["children"]] == [
            ("c", "Scripted", {"instance": a, "steps": plan.steps[a]}) for a in range(len(run.result()["children"]))]
        if run.outcome is not None:
            outcome, tick = run.outcome.status, k
            break
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
    lost = sorted((d, i, o) for i, (o, d) in enumerate(children) if o in ("failed", "aborted") and tick is not None
                  and d <= tick)
    if lost and (failure == "one" or len(lost) == len(children)):  # failed by the failure policy: who and why
        assert run.outcome.reason == "; ".join(f"c{i} {o}: c{i} {o}" for _, i, o in lost)  # type: ignore[union-attr]
    for name, plan in plans.items():  # a halted child: halted in the deciding tick, never stepped again
        if got.get(name) == "halted":
            assert plan.halts == [(0, tick)] and plan.steps == [tick + 1]
            # its halt's stop command replaces the command its step sent in that tick
            assert run.sent[-1][f"motor_{name}"] == "stopped"  # type: ignore[attr-defined]
            assert full[name]["reason"] == f"'par' {want}"
            assert full[name]["sim_time"] == pytest.approx(tick * DT, abs=2e-6)
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
    tick = end_tick(run)
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
    assert text.startswith(f"{ROLES[kind]} 'bad' (<scripted>) raised during ")
    assert re.search(r"ValueError: a bug in the child[^(]*\(at [^)]*test_prop_composites\.py:\d+\)$", text)
    assert err.value.type_name == "Raising" and isinstance(err.value.__cause__, ValueError)


class Same(Behaviour):
    """Commands the actuator ``arm`` every step."""

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        return {"arm": self.name, f"own_{self.name}": 1}


def test_two_parallel_children_commanding_one_actuator_is_an_error_naming_it() -> None:
    from robokit.errors import PluginError

    par = Parallel("par", ParallelConfig())
    par.add_children([Member.of(Same("a", None)), Member.of(Same("b", None))])
    with pytest.raises(PluginError) as err:
        ScriptedRun(par).step({})
    assert str(err.value) == "parallel 'par': two children sent a command to actuator 'arm' in the same tick"
    one = Parallel("par", ParallelConfig())
    one.add_children([Member.of(Same("a", None)), Member.of(Scripted("b", Plan([(None, 0)])))])
    assert ScriptedRun(one).step({}) == {"arm": "a", "own_a": 1, "motor_b": 0}


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


# ------------------------------------------------------------------------------------------ rates
class Timed(Scripted):
    """A scripted child that also notes the tick of each of its steps."""

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        self.config.ticks.setdefault(self.instance, []).append(round(t / DT))
        return super().step(readings, t)


@PROPS
@given(st.sampled_from(["sequence", "fallback", "parallel"]),
       st.lists(st.tuples(st.sampled_from(ENDS), st.integers(0, 3), st.integers(1, 3)), min_size=2, max_size=3))
def test_a_childs_rate_counts_from_its_own_first_tick(kind: str, children: list) -> None:
    """docs: a child's ``rate_hz`` counts ticks from its own start. A child stepped every ``p`` ticks and ending on
    its own step ``d + 1`` ends ``d * p`` ticks after it started; the composite's rule is the same as for p = 1."""
    plans = {f"c{i}": Plan([(o, d)]) for i, (o, d, _) in enumerate(children)}
    for plan in plans.values():
        plan.ticks = {}  # type: ignore[attr-defined]
    composite = {"sequence": lambda: Sequence("seq", SequenceConfig()),
                 "fallback": lambda: Fallback("fb", FallbackConfig()),
                 "parallel": lambda: Parallel("par", ParallelConfig())}[kind]()
    composite.add_children([Member.of(Timed(n, plan), period=p) for (n, plan), (_, _, p) in zip(plans.items(), children,
                                                                                             strict=True)])
    run = ScriptedRun(composite)
    tick = end_tick(run)
    in_ticks = [(o, d * p) for o, d, p in children]
    want, want_tick, _ = expect_parallel(in_ticks, "all", "one") if kind == "parallel" else expect_ordered(kind,
                                                                                                          in_ticks)
    assert (run.outcome.status if run.outcome else None, tick) == (want, want_tick)
    for r in run.result()["steps" if kind == "sequence" else "children"]:
        if r["outcome"] == "not started":
            continue
        i = int(r["name"][1:])
        start = round(r["started_at"] / DT)
        last = tick if r["outcome"] == "halted" else start + round(r["sim_time"] / DT)
        steps = plans[r["name"]].ticks[0]  # type: ignore[attr-defined]
        assert steps == list(range(start, last + 1, children[i][2]))  # every p-th tick from its start, to its end


# ------------------------------------------------------------------------------------------ halted from outside
@PROPS
@given(st.sampled_from(list(ROLES)), st.lists(child, min_size=2, max_size=3), st.integers(0, 8))
def test_a_composite_halted_from_outside_halts_exactly_its_running_children(kind: str, children: list,
                                                                            at: int) -> None:
    """A composite that is itself halted (a monitor's abort, an enclosing timeout) halts every child started and
    not ended: each one's ``halt(t)`` runs once, its stop commands are returned together, its record says halted
    with the composite's name; children not started stay not started. Judged from the children's own step counts."""
    if kind in ("retry", "timeout"):
        children = children[:1]
    plans = {f"c{i}": Plan([c] if kind != "retry" else children) for i, c in enumerate(children)}
    composite = {"sequence": lambda: Sequence("comp", SequenceConfig()),
                 "fallback": lambda: Fallback("comp", FallbackConfig()),
                 "retry": lambda: Retry("comp", RetryConfig(attempts=3)),
                 "timeout": lambda: Timeout("comp", TimeoutConfig(seconds=100 * DT)),
                 "parallel": lambda: Parallel("comp", ParallelConfig(success="all", failure="all"))}[kind]()
    composite.add_children([Member.of(Scripted(n, plan)) for n, plan in plans.items()])
    run = ScriptedRun(composite)
    for _ in range(at):
        run.step({})
    if run.outcome is not None:
        return
    running = []  # the instance each plan is on was stepped and has not reached its end
    for name, plan in plans.items():
        instance = plan.built - 1
        outcome, d = plan.entries[min(instance, len(plan.entries) - 1)]
        if plan.steps[instance] and (outcome is None or plan.steps[instance] < d + 1):
            running.append((name, instance))
    commands = composite.halt(at * DT)
    assert commands == ({f"motor_{n}": "stopped" for n, _ in running} or None)
    for name, plan in plans.items():
        assert plan.halts == [(i, at) for n, i in running if n == name]
    key = "steps" if kind == "sequence" else "children"
    halted = {r["name"]: r for r in run.result()[key] if r["outcome"] == "halted"}
    assert sorted(halted) == sorted(n for n, _ in running)
    for r in halted.values():
        assert r["reason"] == "'comp' was halted"
        assert r["sim_time"] == pytest.approx(at * DT - r["started_at"], abs=2e-6)
    assert [(x["composite"], x["child"]) for x in run.trace if x["kind"] == "child_halt"] == [
        ("comp", n) for n, _ in running]
    assert composite.halt((at + 1) * DT) is None  # nothing runs any more
    assert all(len(p.halts) <= 1 for p in plans.values())


# ------------------------------------------------------------------------------------------ a child's faults
class NoResult(Scripted):
    """A scripted child whose ``result()`` raises."""

    def result(self) -> dict[str, Any]:
        raise ValueError(f"no result from {self.name}")


@PROPS
@given(st.sampled_from(list(ROLES)), st.lists(child, min_size=2, max_size=3))
def test_a_child_whose_result_raises_leaves_every_other_record_whole(kind: str, children: list) -> None:
    """docs: a run's result survives a faulty child. A child whose ``result()`` raises has ``result_error`` (its
    exception's type and text) in its record's result; every other field and record stays."""
    if kind in ("retry", "timeout"):
        children = children[:1]
    plans = {f"c{i}": Plan([c] if kind != "retry" else children) for i, c in enumerate(children)}
    composite = {"sequence": lambda: Sequence("comp", SequenceConfig()),
                 "fallback": lambda: Fallback("comp", FallbackConfig()),
                 "retry": lambda: Retry("comp", RetryConfig(attempts=3)),
                 "timeout": lambda: Timeout("comp", TimeoutConfig(seconds=5 * DT)),
                 "parallel": lambda: Parallel("comp", ParallelConfig())}[kind]()
    composite.add_children([Member.of(NoResult(n, plan)) for n, plan in plans.items()])
    run = ScriptedRun(composite)
    for _ in range(12):
        run.step({})
    records_ = run.result()["steps" if kind == "sequence" else "children"]
    assert records_, "a composite always lists its children"
    for r in records_:
        assert r["result"] == ({} if r["outcome"] == "not started" else
                               {"result_error": f"ValueError: no result from {r['name']}"})
        assert set(r) >= {"name", "type", "outcome", "reason", "result"}


class SetsUp(Scripted):
    """A scripted child that counts its set-ups and writes a trace record in ``setup`` and in each step."""

    def setup(self, ctx: Any) -> None:
        super().setup(ctx)
        self.config.setups = getattr(self.config, "setups", 0) + 1
        ctx.trace("child_note", when="setup")

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any]:
        self.ctx.trace("child_note", when="step")
        return super().step(readings, t)


class BadSetup(Behaviour):
    def setup(self, ctx: Any) -> None:
        raise KeyError("no such arm")


@pytest.mark.parametrize("kind", list(ROLES))
def test_children_of_a_hand_built_tree_are_set_up_once_their_records_named(kind: str) -> None:
    """A tree built by hand: the composite sets up each child not yet set up, once (with its own trace records
    tagged ``child_source``); a child already set up is left as it is; a child whose setup raises is one error
    naming its role, the call, where it raised and its type."""
    from robokit.errors import PluginError

    plan, ready = Plan([("succeeded", 1)]), Plan([("succeeded", 1)])
    make = {"sequence": lambda: Sequence("comp", SequenceConfig()),
            "fallback": lambda: Fallback("comp", FallbackConfig()),
            "retry": lambda: Retry("comp", RetryConfig(attempts=2)),
            "timeout": lambda: Timeout("comp", TimeoutConfig(seconds=1.0)),
            "parallel": lambda: Parallel("comp", ParallelConfig())}[kind]
    composite = make()
    first = SetsUp("a", plan)
    members = [Member.of(first)]
    if kind in ("sequence", "fallback", "parallel"):
        other = SetsUp("b", ready)
        other.setup(ScriptedRun(Scripted("x", Plan([(None, 0)]))).ctx)  # set up elsewhere already
        members.append(Member.of(other))
    composite.add_children(members)
    run = ScriptedRun(composite)
    for _ in range(3):
        run.step({})
    assert plan.setups == 1 and getattr(ready, "setups", 1) == 1  # type: ignore[attr-defined]
    notes = [(x["source"], x.get("child_source"), x["when"]) for x in run.trace if x["kind"] == "child_note"]
    assert notes[0] == ("behaviour", "a", "setup") and ("behaviour", "a", "step") in notes  # the run's own trace
    assert all(src == "a" for _, src, _ in notes)  # the pre-set-up child writes to its own trace, not this one

    bad = make()
    bad.add_children([Member("wrong", "bad_setup", BadSetup("wrong", None), 1, "type 'bad_setup' from tests")]
                     + ([Member.of(Scripted("b", Plan([(None, 0)])))] if kind == "parallel" else []))
    with pytest.raises(PluginError) as err:
        ScriptedRun(bad)
    text = str(err.value)
    assert text.startswith(f"{ROLES[kind]} 'wrong' (type 'bad_setup' from tests) raised during setup: "
                           "KeyError: 'no such arm'")
    assert re.search(r"\(at [^)]*test_prop_composites\.py:\d+\)$", text)
    assert err.value.type_name == "bad_setup" and isinstance(err.value.__cause__, KeyError)


class Closes(Scripted):
    def close(self) -> None:
        self.config.closed.append(self.instance)
        if self.name == "c0":
            raise RuntimeError("close failed")


@PROPS
@given(st.lists(child, min_size=1, max_size=4), st.integers(1, 4))
def test_every_attempt_and_every_child_is_closed(attempts_plan: list, attempts: int) -> None:
    """A retry closes each attempt's instance before the next starts; closing a composite closes every child, even
    after one child's ``close`` raised."""
    plan = Plan(attempts_plan)
    plan.closed = []  # type: ignore[attr-defined]
    retry = Retry("retry", RetryConfig(attempts=attempts))
    retry.add_children([Member.of(Closes("c0", plan))])
    run = ScriptedRun(retry)
    for _ in range(HORIZON):
        run.step({})
    assert plan.closed == list(range(plan.built - 1))  # type: ignore[attr-defined]  # all but the last attempt
    retry.close()
    assert plan.closed == list(range(plan.built))  # type: ignore[attr-defined]
    plans = [Plan([(None, 0)]) for _ in range(3)]
    for p in plans:
        p.closed = []  # type: ignore[attr-defined]
    par = Parallel("par", ParallelConfig())
    par.add_children([Member.of(Closes(f"c{i}", p)) for i, p in enumerate(plans)])
    ScriptedRun(par).step({})
    par.close()
    assert [p.closed for p in plans] == [[0], [0], [0]]  # type: ignore[attr-defined]


@PROPS
@given(st.lists(st.tuples(st.sampled_from([*ENDS, None]), st.integers(0, 2)), min_size=1, max_size=3),
       st.lists(st.tuples(st.sampled_from(ENDS), st.integers(0, 2)), min_size=1, max_size=3), st.integers(1, 3),
       st.integers(1, 2))
def test_a_retry_of_a_hand_built_sequence_rebuilds_the_whole_subtree(first: list, second: list, attempts: int,
                                                                     period: int) -> None:
    """Each attempt of a retry is a fresh instance of its child; a composite child comes with fresh instances of
    its own children, stepped at the same rates (a hand-built tree: each class called again with name and
    config)."""
    plans = {"s0": Plan(first), "s1": Plan(second)}
    for p in plans.values():
        p.ticks = {}  # type: ignore[attr-defined]
    seq = Sequence("seq", SequenceConfig())
    seq.add_children([Member("s0", "timed", Timed("s0", plans["s0"]), period, "type 'timed' from s0", "spec s0"),
                      Member("s1", "timed", Timed("s1", plans["s1"]), 1, "type 'timed' from s1", "spec s1")])
    retry = Retry("retry", RetryConfig(attempts=attempts))
    retry.add_children([Member("seq", "sequence", seq, 1, "type 'sequence' from robokit", "spec seq")])

    def fields(m: Member) -> tuple[Any, ...]:
        return m.name, m.type, m.period, m.origin, m.spec

    run = ScriptedRun(retry)
    for _ in range(HORIZON):
        run.step({})
        # every attempt: the same member (name, type, rate, origin, section), its steps' the same
        assert fields(retry.children[0]) == ("seq", "sequence", 1, "type 'sequence' from robokit", "spec seq")
        assert [fields(m) for m in retry.children[0].behaviour.children] == [
            ("s0", "timed", period, "type 'timed' from s0", "spec s0"),
            ("s1", "timed", 1, "type 'timed' from s1", "spec s1")]
    # the oracle: attempt a runs s0's entry a, then (if it succeeded) s1's; a sequence attempt succeeds iff both did
    tick, made, want = 0, 0, None
    for a in range(attempts):
        made += 1
        o0, d0 = first[min(a, len(first) - 1)]
        if o0 is None:
            break
        assert plans["s0"].ticks[a] == list(range(tick, tick + d0 * period + 1, period))  # type: ignore[attr-defined]
        tick += d0 * period
        outcome = o0
        if o0 == "succeeded":
            o1, d1 = second[min(a, len(second) - 1)]
            tick += 1 + d1
            outcome = o1
        if outcome == "succeeded" or a == attempts - 1:
            want = outcome
            break
        tick += 1
    assert plans["s0"].built == made
    assert (run.outcome.status if run.outcome else None) == want
    assert [m.behaviour for m in retry.children][0] is not seq or made == 1


@PROPS
@given(st.sampled_from(["sequence", "fallback", "parallel"]),
       st.lists(st.tuples(st.integers(0, 3), st.booleans(), st.booleans(), st.sampled_from([True, False, None])),
                min_size=1, max_size=4))
def test_the_final_verdict_of_a_composite_that_succeeded(kind: str, children: list) -> None:
    """docs ("When a goal is checked"): when the run ends, the child that decided a composite that succeeded (a
    sequence's last step, the alternative that succeeded, every child of a parallel) and every child marked
    ``must_last`` that succeeded are asked again; met only if all are; a child with no section (a hand-built one)
    is not ``must_last``. Every child here succeeds, with a goal met when it ends or no goal at all."""
    if kind == "parallel" and len(children) < 2:
        children = children * 2
    members = []
    for i, (d, goal, later, must_last) in enumerate(children):
        plan = Plan([("succeeded", d)])
        plan.goals = (True, later)  # type: ignore[attr-defined]
        child = Goaled(f"c{i}", plan) if goal else Scripted(f"c{i}", plan)
        spec = None if must_last is None else SimpleNamespace(must_last=must_last)
        members.append(Member(f"c{i}", "Scripted", child, 1, "<scripted>", spec))
    composite = {"sequence": lambda: Sequence("seq", SequenceConfig()),
                 "fallback": lambda: Fallback("fb", FallbackConfig()),
                 "parallel": lambda: Parallel("par", ParallelConfig())}[kind]()
    composite.add_children(members)
    run = ScriptedRun(composite)
    for _ in range(HORIZON):
        run.step({})
        if run.outcome is not None:
            break
    assert run.outcome is not None and run.outcome.status == "succeeded"
    ran = {"sequence": range(len(children)), "fallback": range(1), "parallel": range(len(children))}[kind]
    deciding = {"sequence": [len(children) - 1], "fallback": [0], "parallel": list(ran)}[kind]
    final = sorted(set(deciding) | {i for i in ran if children[i][3]})
    asked = [i for i in final if children[i][1]]
    verdict = composite.check_goal(run.world)
    if not asked:
        assert verdict is None
        return
    assert verdict is not None and verdict.met == all(children[i][2] for i in asked)
    key = "steps" if kind == "sequence" else "children"
    assert {n: (v["met"], v["reason"]) for n, v in verdict.details[key].items()} == {
        f"c{i}": (children[i][2], f"c{i} {'met' if children[i][2] else 'not met'}") for i in asked}
    missed = [f"c{i}: c{i} not met" for i in asked if not children[i][2]]
    assert sorted(verdict.reason.split("; ")) == sorted(missed or [f"c{i}: c{i} met" for i in asked])


class BadGoal(Scripted):
    """Ends succeeded after its plan; its ``check_goal`` raises, when the child ends (``at_end``) or when asked
    again at the run's end."""

    def __init__(self, name: str, config: Plan) -> None:
        super().__init__(name, config)
        self.asked = 0

    def check_goal(self, world: Any) -> GoalCheck:
        self.asked += 1
        if self.config.raise_at == self.asked:  # type: ignore[attr-defined]
            raise RuntimeError("goal check broke")
        return GoalCheck(True, "fine")


@pytest.mark.parametrize("kind", list(ROLES))
@pytest.mark.parametrize("when", [1, 2])
def test_a_goal_check_that_raises_is_named_with_the_childs_role(kind: str, when: int) -> None:
    from robokit.errors import PluginError

    plan = Plan([("succeeded", 1)])
    plan.raise_at = when  # type: ignore[attr-defined]
    composite = {"sequence": lambda: Sequence("c", SequenceConfig()),
                 "fallback": lambda: Fallback("c", FallbackConfig()),
                 "retry": lambda: Retry("c", RetryConfig(attempts=2)),
                 "timeout": lambda: Timeout("c", TimeoutConfig(seconds=1.0)),
                 "parallel": lambda: Parallel("c", ParallelConfig())}[kind]()
    members = [Member("bad", "bad_goal", BadGoal("bad", plan), 1, "type 'bad_goal' from tests")]
    if kind == "parallel":
        members.append(Member.of(Scripted("other", Plan([("succeeded", 0)]))))
    composite.add_children(members)
    run = ScriptedRun(composite)
    with pytest.raises(PluginError) as err:
        for _ in range(HORIZON):
            run.step({})
            if run.outcome is not None:
                composite.check_goal(run.world)  # the run's final verdict asks again
                break
    assert str(err.value).startswith(f"{ROLES[kind]} 'bad' (type 'bad_goal' from tests) raised during check_goal: "
                                     "RuntimeError: goal check broke")
    assert err.value.type_name == "bad_goal"


def test_two_children_halted_together_commanding_one_actuator_is_an_error_naming_the_composite() -> None:
    from robokit.errors import PluginError

    class HaltsArm(Scripted):
        def halt(self, t: float) -> Mapping[str, Any]:
            return {"arm": "hold"}

    par = Parallel("par", ParallelConfig())
    par.add_children([Member.of(HaltsArm(n, Plan([(None, 0)]))) for n in ("a", "b")])
    ScriptedRun(par).step({})
    with pytest.raises(PluginError) as err:
        par.halt(DT)
    assert str(err.value) == "par: two children sent a command to actuator 'arm' in the same tick"


# ------------------------------------------------------------------------------------------ built by the simulation
class FlakyConfig(Section):
    """``type = "flaky"``: fails its first ``fail_first`` instances' first step, then succeeds."""

    fail_first: int = setting(2, ge=0)


class Flaky(Behaviour):
    built: list[Flaky] = []

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.index = len(Flaky.built)
        Flaky.built.append(self)

    def step(self, readings: Mapping[str, Any], t: float) -> None:
        self.finish("failed" if self.index < self.config.fail_first else "succeeded", f"instance {self.index}")

    def result(self) -> dict[str, Any]:
        return {"instance": self.index, "set_up": self.ctx is not None}


class FlakyPlugin:
    @hookimpl
    def robokit_register_behaviours(self, register: Any) -> None:
        register("flaky", Flaky, FlakyConfig)


@pytest.mark.parametrize("fail_first", [2, 5])
def test_a_retry_built_from_a_config_runs_a_fresh_set_up_instance_from_its_section_each_attempt(
        fail_first: int) -> None:
    """Through the simulation (a config, not a hand-built tree): each attempt is a new instance built from the
    child's section (its options kept), set up before its first step; the retry's record lists every attempt."""
    from robokit.testing import make_sim

    Flaky.built = []
    config = {"behaviour": {"type": "retry", "attempts": 4,
                            "child": {"type": "flaky", "name": "flaky_child", "fail_first": fail_first}}}
    with make_sim(config, extra_plugins=(FlakyPlugin(),)) as sim:
        result = sim.run(max_time=1.0)
        member = sim.behaviour.children[0]
        assert (member.name, member.type, member.spec.name) == ("flaky_child", "flaky", "flaky_child")
    made = min(fail_first + 1, 4)
    assert len(Flaky.built) == made and len({id(b) for b in Flaky.built}) == made
    assert all(b.config.fail_first == fail_first for b in Flaky.built)
    assert result.outcome == ("succeeded" if fail_first < 4 else "failed")
    assert result.result["attempts"] == made
    assert [(r["name"], r["outcome"], r["result"]) for r in result.result["children"]] == [
        ("flaky_child", "failed" if i < fail_first else "succeeded", {"instance": i, "set_up": True})
        for i in range(made)]
