"""Composites: behaviours made of behaviours, the vocabulary of behaviour trees over robokit's state machines.

========== =========================================================== ==========================================
type       rule                                                        children
========== =========================================================== ==========================================
sequence   run children in order; the first that does not succeed      ``[[behaviour.steps]]`` (one or more)
           ends it with that outcome; succeeds when all succeeded
fallback   run children in order; the first that succeeds ends it      ``[[behaviour.children]]`` (one or more)
           (succeeded); fails when every child failed or aborted
retry      run the child up to ``attempts`` times, each a fresh        ``[behaviour.child]`` (exactly one)
           instance; succeeds at its first success
timeout    run the child; halt it and fail when it has not ended       ``[behaviour.child]`` (exactly one)
           ``seconds`` (sim time) after it started
parallel   step every child each tick; ``success``/``failure``       ``[[behaviour.children]]`` (two or more)
           policies (``"all"`` or ``"one"``) decide; the others are
           halted then
========== =========================================================== ==========================================

Composites nest (a child may be any behaviour, composites included). **One clock**: every child's ``step`` receives
the world's sim time ``t``; a child's own stopwatch is ``behaviour.elapsed(t)`` (its ``started_at`` is set when its
composite starts it). A child started after another one ended starts at the next tick; a child's ``rate_hz``
counts ticks from its own start.

**Goals**: a child's goal (its ``check_goal(world)``) is judged the tick the child ends and decides its outcome
(met: ``succeeded``, not met: ``failed``), recorded in its child record; each rule above goes by those judged
outcomes. When the run ends, only the child that decided the composite (a sequence's last step, the alternative
that succeeded, ...) and children marked ``must_last`` are asked again (:meth:`Composite.check_goal`).

A child that is stopped before it ends (a timeout, a parallel decided, a monitor's abort) is **halted**: its
optional ``halt(t)`` method runs (return commands to stop what it started, e.g. ``{"arm": HoldArm()}``) and it is
never stepped again. Every start, end and halt is a trace record (``child_start``, ``child_end``, ``child_halt``;
a sequence writes ``step_start`` and ``step_end``) naming the composite and the child.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

from robokit import hookimpl
from robokit.components import Outcome, SetupContext
from robokit.config.sections import Section, setting
from robokit.core.composite_base import Composite as Composite
from robokit.core.composite_base import Member as Member
from robokit.core.composite_base import Ordered
from robokit.core.composite_base import call as call
from robokit.core.composite_base import merge as merge


class SequenceConfig(Section):
    """``type = "sequence"``: the steps are ``[[behaviour.steps]]`` tables (read by the config loader)."""


class Sequence(Ordered):
    """Runs behaviours one after another: each starts when the previous one succeeded."""

    CHILDREN_KEY = "steps"
    ROLE = "sequence step"

    def _kind(self, what: str) -> str:
        return f"step_{what}"

    def _label(self) -> str:
        return "step"

    @property
    def steps(self) -> list[Member]:
        return self.children

    def _stop(self, member: Member, outcome: Outcome) -> tuple[str, str]:
        return outcome.status, (f"step {self.index + 1} {member.name!r} ({member.type}) {outcome.status}: "
                                f"{outcome.reason}")

    def _exhausted(self) -> tuple[str, str]:
        return "succeeded", f"all {len(self.children)} steps succeeded"

    def final(self) -> list[Member]:
        """The last step: what must still hold when the run ends (each earlier step's goal was judged when it
        ended; a step with ``must_last = true`` is checked again at the end too)."""
        return self.children[-1:] if self.children and self.children[-1].record.get("outcome") == "succeeded" else []

    def result(self) -> dict[str, Any]:
        """Per step: name, type, outcome, reason, start and duration (sim s) and the step's own result."""
        steps = [self._with_result(r) for r in self._records()]
        done = sum(1 for r in self.runs if r["outcome"] == "succeeded")
        return {"steps_completed": done, "steps": steps}


class FallbackConfig(Section):
    """``type = "fallback"``: the alternatives are ``[[behaviour.children]]`` tables, tried in order."""


class Fallback(Ordered):
    """Tries alternatives in order: the first that succeeds ends it; it fails when every one failed."""

    CONTINUE_ON = "failed"
    ROLE = "fallback child"

    def _after(self, member: Member, outcome: Outcome) -> None:
        if outcome.status == "aborted":  # an aborted alternative counts as failed: try the next
            outcome = Outcome("failed", outcome.reason)
        super()._after(member, outcome)

    def _stop(self, member: Member, outcome: Outcome) -> tuple[str, str]:
        return "succeeded", f"alternative {self.index + 1} {member.name!r} succeeded: {outcome.reason}"

    def _exhausted(self) -> tuple[str, str]:
        reasons = "; ".join(f"{r['name']}: {r['reason']}" for r in self.runs)
        return "failed", f"all {len(self.children)} alternatives failed ({reasons})"


class RetryConfig(Section):
    """``type = "retry"``: the child is ``[behaviour.child]``."""

    attempts: int = setting(3, ge=1, le=1000, description="tries in all, each a fresh instance of the child")


class Retry(Composite):
    """Runs its child until it succeeds, at most ``attempts`` times; each attempt is a fresh instance."""

    CHILDREN_KEY = "child"
    ARITY = (1, 1)
    ROLE = "retry child"

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config or RetryConfig())
        self.attempt = 0
        self._next_at = 0

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self._next_at = self.clock.tick

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        member = self.children[0]
        if self.outcome is not None or self.clock.tick < self._next_at:
            return None
        if member.record.get("outcome") != "running":
            self.attempt += 1
            self.begin(member, t, self.attempt - 1)
        commands = self.tick_child(member, readings, t)
        outcome = member.behaviour.outcome
        if outcome is None:
            return commands
        outcome = self.end(member, outcome, t, self.attempt - 1)
        if outcome.status == "succeeded":
            self.finish("succeeded", f"attempt {self.attempt} of {self.config.attempts} succeeded: {outcome.reason}")
        elif self.attempt >= self.config.attempts:
            self.finish(outcome.status, f"{self.attempt} attempt(s) failed; last: {outcome.reason}")
        else:
            self._fresh(member)
        return commands

    def _fresh(self, member: Member) -> None:
        member.record["result"] = self._with_result(member.record)["result"]  # the attempt's own, kept
        try:
            member.behaviour.close()
        except Exception:  # noqa: BLE001, S110 - the next attempt must start
            pass
        self.children[0] = self.fresh(member)
        self._next_at = self.clock.tick + 1

    def result(self) -> dict[str, Any]:
        """Attempts made, and every attempt's record (the last with the child's own result)."""
        runs = [dict(r) for r in self.runs] + [m.record for m in self.running()]
        if runs:
            runs[-1] = self._with_result(runs[-1])
        return {"attempts": self.attempt, "children": runs}


class TimeoutConfig(Section):
    """``type = "timeout"``: the child is ``[behaviour.child]``."""

    seconds: float = setting(gt=0.0, description="sim seconds the child may run, from its start (more than 0)")


class Timeout(Composite):
    """Runs its child; when the child has not ended ``seconds`` after it started, halts it and fails."""

    CHILDREN_KEY = "child"
    ARITY = (1, 1)
    ROLE = "timeout child"

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        member = self.children[0]
        if self.outcome is not None:
            return None
        if member.record.get("outcome") != "running":
            self.begin(member, t, 0)
        if member.behaviour.elapsed(t) > self.config.seconds + 1e-9:
            why = f"{member.name!r} did not end within {self.config.seconds:g} s (sim time)"
            commands = self.halt_child(member, t, why)
            self.finish("failed", f"timed out: {why}")
            return commands
        commands = self.tick_child(member, readings, t)
        outcome = member.behaviour.outcome
        if outcome is not None:
            outcome = self.end(member, outcome, t, 0)
            self.finish(outcome.status, outcome.reason)
        return commands


class ParallelConfig(Section):
    """``type = "parallel"``: the children are ``[[behaviour.children]]``, all stepped every tick."""

    success: Literal["all", "one"] = setting("all", description="succeed when all / one of the children succeeded")
    failure: Literal["one", "all"] = setting("one", description="fail when one / all of the children failed")


class Parallel(Composite):
    """Steps every child each tick; the ``success`` and ``failure`` policies decide when it ends (the children
    still running then are halted). A child that aborts counts as failed."""

    ARITY = (2, None)
    ROLE = "parallel child"

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self._started = False

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        if self.outcome is not None:
            return None
        if not self._started:
            self._started = True
            for i, member in enumerate(self.children):
                self.begin(member, t, i)
        commands: dict[str, Any] = {}
        for i, member in enumerate(self.children):
            if member.record.get("outcome") != "running":
                continue
            merge(commands, self.tick_child(member, readings, t), f"parallel {self.name!r}")
            if member.behaviour.outcome is not None:
                self.end(member, member.behaviour.outcome, t, i)
        decided = self._decide()
        if decided is not None:
            for member in self.running():  # a halted child's stop commands replace what it sent this tick
                commands.update(self.halt_child(member, t, f"{self.name!r} {decided[0]}") or {})
            self.finish(*decided)
        return commands or None

    def _decide(self) -> tuple[str, str] | None:
        n = len(self.children)
        won = [r for r in self.runs if r["outcome"] == "succeeded"]
        lost = [r for r in self.runs if r["outcome"] in ("failed", "aborted")]
        cfg = self.config
        if lost and (cfg.failure == "one" or len(lost) == n):
            return "failed", "; ".join(f"{r['name']} {r['outcome']}: {r['reason']}" for r in lost)
        if won and (cfg.success == "one" or len(won) == n):
            return "succeeded", f"{len(won)} of {n} children succeeded"
        if len(won) + len(lost) == n:  # everyone ended and no policy was met (success "all", failure "all")
            return "failed", f"{len(won)} of {n} children succeeded; success policy {cfg.success!r} not met"
        return None


COMPOSITES: dict[str, tuple[type[Composite], type[Section]]] = {
    "sequence": (Sequence, SequenceConfig),
    "fallback": (Fallback, FallbackConfig),
    "retry": (Retry, RetryConfig),
    "timeout": (Timeout, TimeoutConfig),
    "parallel": (Parallel, ParallelConfig),
}


@hookimpl
def robokit_register_behaviours(register: Any) -> None:
    for type_name, (cls, schema) in COMPOSITES.items():
        register(type_name, cls, schema)
