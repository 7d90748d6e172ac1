"""The base of composites: :class:`Member` (a child and its bookkeeping), :class:`Composite` (start, step, end and
halt children on one clock; results, goals, close) and :class:`Ordered` (children one after another). The concrete
composites and their rules are in :mod:`robokit.core.composites`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from collections.abc import Sequence as Seq
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from robokit.components import Behaviour, GoalCheck, Outcome, SetupContext
from robokit.errors import PluginError
from robokit.process.crash import describe, where_raised


@dataclass
class Member:
    """A behaviour inside a composition: its name, instance, period in ticks and origin (for error messages).

    ``spec`` is the config section it was built from (a retry builds a fresh instance from it); ``start_tick`` is
    the tick of its first step (its rate counts from there)."""

    name: str
    type: str
    behaviour: Any
    period: int
    origin: str
    spec: Any = None
    start_tick: int = 0
    record: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, behaviour: Any, period: int = 1) -> Member:
        """A member for a behaviour built by hand (a scripted test's tree): named after it, stepped every
        ``period`` ticks."""
        return cls(behaviour.name, type(behaviour).__name__, behaviour, period, "<scripted>")


def call(member: Member, role: str, what: str, fn: Any, *args: Any) -> Any:
    """Call a member's method; anything it raises becomes a PluginError naming it, its role and origin."""
    try:
        return fn(*args)
    except PluginError:
        raise
    except Exception as exc:
        where = where_raised(exc)
        raise PluginError(f"{role} {member.name!r} ({member.origin}) raised during {what}: {describe(exc)}"
                          + (f" (at {where})" if where else ""), type_name=member.type) from exc


def merge(commands: dict[str, Any], more: Mapping[str, Any] | None, who: str) -> None:
    """Add a child's commands; two children commanding one actuator in the same tick is an error."""
    for name, cmd in (more or {}).items():
        if name in commands:
            raise PluginError(f"{who}: two children sent a command to actuator {name!r} in the same tick")
        commands[name] = cmd


class Composite(Behaviour):
    """Base of composites: children as :class:`Member` objects, started, stepped, ended and halted on one clock.

    Class attributes:
        CHILDREN_KEY: The config key holding the children (``steps``, ``children`` or ``child``).
        ARITY: Least and most children (None = no limit), checked when the config is read.
    """

    CHILDREN_KEY: ClassVar[str] = "children"
    ARITY: ClassVar[tuple[int, int | None]] = (1, None)
    ROLE: ClassVar[str] = "child"

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.children: list[Member] = []
        self.runs: list[dict[str, Any]] = []
        self.rebuild: Callable[[Member], Member] | None = None
        """Builds a fresh, set-up instance of a child (the simulation provides it; a retry needs it)."""

    def add_children(self, members: Seq[Member]) -> None:
        """Give the composite its children (built and set up by the simulation from the config)."""
        self.children = list(members)

    def add_steps(self, steps: Seq[Member]) -> None:  # the name sequences have always used
        self.add_children(steps)

    def setup(self, ctx: SetupContext) -> None:
        """Keep the clock and the trace writer. Children not set up yet (a tree built by hand, as in a scripted
        test) are set up here with this context, their trace records under their own names."""
        super().setup(ctx)
        self.clock = ctx.world
        self._trace = ctx.trace
        for member in self.children:
            self._adopt(member)

    def _adopt(self, member: Member) -> None:
        if getattr(member.behaviour, "ctx", None) is not None:
            return
        ctx = self.ctx
        trace = ctx.trace

        def child_trace(kind: str, **data: Any) -> None:
            trace(kind, **{"child_source": member.name, **data})

        call(member, self.ROLE, "setup", member.behaviour.setup, replace(ctx, trace=child_trace))

    def fresh(self, member: Member) -> Member:
        """A new, set-up instance of a child (what a retry runs for each attempt): built by the simulation, or,
        in a tree built by hand, the child's class called again with its name and config."""
        if self.rebuild is not None:
            return self.rebuild(member)
        new = Member(member.name, member.type, _clone(member.behaviour), member.period, member.origin, member.spec)
        self._adopt(new)
        return new

    # ------------------------------------------------------------------ children's lives
    def begin(self, member: Member, t: float, index: int) -> None:
        """Start a child now (its first step is this tick): its stopwatch and rate start here."""
        member.behaviour.started_at = t
        member.start_tick = self.clock.tick
        member.record = {"name": member.name, "type": member.type, "outcome": "running", "reason": "",
                         "started_at": round(t, 6)}
        self._trace(self._kind("start"), composite=self.name, **{self._label(): member.name}, index=index,
                    type=member.type)

    def tick_child(self, member: Member, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Step a running child if it is due (its period counts from its own first tick)."""
        if (self.clock.tick - member.start_tick) % member.period:
            return None
        return call(member, self.ROLE, "step", member.behaviour.step, readings, t)  # type: ignore[no-any-return]

    def end(self, member: Member, outcome: Outcome, t: float, index: int) -> Outcome:
        """Book a child's end in the result and the trace, its goal judged on the world now (:meth:`judge`).

        Returns the judged outcome: the one the composite's rule goes by."""
        outcome = self.judge(member, outcome)
        member.record.update(outcome=outcome.status, reason=outcome.reason,
                             sim_time=round(t - member.record["started_at"], 6))
        self.runs.append(member.record)
        self._trace(self._kind("end"), composite=self.name, **{self._label(): member.name}, index=index,
                    outcome=outcome.status, reason=outcome.reason)
        return outcome

    def judge(self, member: Member, outcome: Outcome) -> Outcome:
        """A child's goal, judged on the world the moment the child ends, as a run's goal is when the run ends.

        A child that states a goal (its ``check_goal(world)``) has it recorded in its record (``goal``: met,
        reason, details). For a child that ended ``succeeded`` or ``failed`` the world decides: met is
        ``succeeded``, not met is ``failed``, and the child's own claim is kept under ``claimed``. ``aborted`` stands.
        """
        hook = getattr(member.behaviour, "check_goal", None)
        check = call(member, self.ROLE, "check_goal", hook, self.ctx.world) if hook is not None else None
        if check is None:
            return outcome
        met = bool(check.met)
        member.record["goal"] = {"met": met, "reason": check.reason, **dict(check.details)}
        self._trace("goal", composite=self.name, child=member.name, met=met, reason=check.reason)
        if outcome.status not in ("succeeded", "failed") or met == (outcome.status == "succeeded"):
            return outcome
        member.record["claimed"] = {"outcome": outcome.status, "reason": outcome.reason}
        claim = f" ({member.name} reported {outcome.status}: {outcome.reason})"
        if met:
            return Outcome("succeeded", f"goal met: {check.reason}{claim}")
        return Outcome("failed", f"goal not met: {check.reason}{claim}")

    def halt_child(self, member: Member, t: float, reason: str) -> Mapping[str, Any] | None:
        """Stop a running child before it ended: its ``halt(t)`` runs (its commands are returned), it is booked
        ``halted`` and never stepped again."""
        hook = getattr(member.behaviour, "halt", None)
        commands = call(member, self.ROLE, "halt", hook, t) if hook is not None else None
        member.record.update(outcome="halted", reason=reason, sim_time=round(t - member.record["started_at"], 6))
        self.runs.append(member.record)
        self._trace("child_halt", composite=self.name, child=member.name, reason=reason)
        return commands  # type: ignore[no-any-return]

    def halt(self, t: float) -> Mapping[str, Any] | None:
        """Halt every running child (this composite is itself being halted)."""
        commands: dict[str, Any] = {}
        for member in self.running():
            merge(commands, self.halt_child(member, t, f"{self.name!r} was halted"), self.name)
        return commands or None

    def running(self) -> list[Member]:
        """Children started and not ended."""
        return [m for m in self.children if m.record.get("outcome") == "running"]

    def _kind(self, what: str) -> str:
        return f"child_{what}"

    def _label(self) -> str:
        return "child"

    # ------------------------------------------------------------------ result, goal, close
    def result(self) -> dict[str, Any]:
        """Every child run (name, type, outcome, reason, start and duration in sim s, its own result)."""
        return {"children": [self._with_result(r) for r in self._records()]}

    def _records(self) -> list[dict[str, Any]]:
        booked = list(self.runs)
        booked += [m.record for m in self.running() if m.record not in booked]
        names = {r["name"] for r in booked}
        return booked + [{"name": m.name, "type": m.type, "outcome": "not started", "reason": ""}
                         for m in self.children if m.name not in names]

    def _with_result(self, record: dict[str, Any]) -> dict[str, Any]:
        member = next((m for m in self.children if m.name == record["name"]), None)
        own: dict[str, Any] = record.get("result", {})
        if "result" not in record and member is not None and record["outcome"] != "not started":
            try:
                own = dict(member.behaviour.result())
            except Exception as exc:  # noqa: BLE001 - the run's result must survive a faulty child
                own = {"result_error": f"{type(exc).__name__}: {exc}"}
        return {**record, "result": own}

    def final(self) -> list[Member]:
        """The children whose goals must still hold when the run ends (a composite that succeeded): each child
        that succeeded, and any child whose section says ``must_last = true``. A sequence narrows this to its last
        step (:class:`robokit.core.composites.Sequence`)."""
        return [m for m in self.children if m.record.get("outcome") == "succeeded"]

    def check_goal(self, world: Any) -> GoalCheck | None:
        """The run's final verdict on a composite: the goals that must still hold at the end (:meth:`final`, and
        every child marked ``must_last``), asked of the world now; met only if all are. None when the composite
        did not succeed (its children's goals were judged as they ended, and its outcome stands) or no such child
        states a goal."""
        if self.outcome is None or self.outcome.status != "succeeded":
            return None
        lasting = [m for m in self.children if getattr(m.spec, "must_last", False)
                   and m.record.get("outcome") == "succeeded"]
        final = self.final()
        members = [*final, *(m for m in lasting if all(m is not f for f in final))]
        checks = []
        for member in members:
            hook = getattr(member.behaviour, "check_goal", None)
            check = call(member, self.ROLE, "check_goal", hook, world) if hook else None
            if check is not None:
                checks.append((member.name, check))
        if not checks:
            return None
        missed = [f"{name}: {c.reason}" for name, c in checks if not c.met]
        details = {name: {"met": c.met, "reason": c.reason, **dict(c.details)} for name, c in checks}
        reason = "; ".join(missed) if missed else "; ".join(f"{name}: {c.reason}" for name, c in checks)
        return GoalCheck(not missed, reason, {self.CHILDREN_KEY: details})

    def close(self) -> None:
        for member in self.children:
            try:
                member.behaviour.close()
            except Exception:  # noqa: BLE001, S110 - closing must reach every child
                pass


def _clone(behaviour: Any) -> Any:
    """A new instance of a behaviour built by hand (its class, name and config), a composite's children too."""
    new = type(behaviour)(behaviour.name, behaviour.config)
    if isinstance(behaviour, Composite):
        new.add_children([Member(m.name, m.type, _clone(m.behaviour), m.period, m.origin, m.spec)
                          for m in behaviour.children])
    return new


class Ordered(Composite):
    """Children one after another (sequence, fallback): ``CONTINUE_ON`` says which outcome moves on."""

    CONTINUE_ON: ClassVar[str] = "succeeded"

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.index = 0
        self._next_at: int | None = None

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self._next_at = self.clock.tick if self.children else None

    @property
    def current(self) -> Member | None:
        """The child running now (None when the composite has ended)."""
        return self.children[self.index] if self.index < len(self.children) and self.outcome is None else None

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        member = self.current
        if member is None or self.clock.tick < (self._next_at or 0):
            return None
        if member.record.get("outcome") != "running":
            self.begin(member, t, self.index)
        commands = self.tick_child(member, readings, t)
        outcome = member.behaviour.outcome
        if outcome is not None:
            self._after(member, self.end(member, outcome, t, self.index))
        return commands

    def _after(self, member: Member, outcome: Outcome) -> None:
        if outcome.status != self.CONTINUE_ON:
            self.finish(*self._stop(member, outcome))
            return
        self.index += 1
        self._next_at = self.clock.tick + 1  # the next child's first step is the next tick
        if self.index == len(self.children):
            self.finish(*self._exhausted())

    def _stop(self, member: Member, outcome: Outcome) -> tuple[str, str]:
        raise NotImplementedError

    def _exhausted(self) -> tuple[str, str]:
        raise NotImplementedError
