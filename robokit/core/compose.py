"""More than one behaviour per config: monitors beside the task, and a sequence of behaviours.

A config has one **task** — its ``[behaviour]`` — and any number of **monitors**::

    [behaviour]                 # the task: its outcome is the run's outcome
    type = "patrol"
    ...

    [monitors.drive_log]        # runs beside the task, at its own rate; observes, never commands
    type = "record"
    components = ["drive"]
    rate_hz = 10

A monitor is any behaviour type. It is stepped after the task in the same tick, with the same readings; it may not
send commands (actuators belong to the task); when it finishes (``record`` after its ``duration``) it is no longer
stepped, and the run goes on until the task ends. Its outcome and result go into the run's result under
``result["monitors"][NAME]``.

The task itself may be a **sequence**: ``type = "sequence"`` with ``[[behaviour.steps]]`` tables, each a behaviour
section of its own (``type``, ``rate_hz``, its options, and an optional ``name``). Each step starts when the
previous one succeeded; the first step that fails (or is aborted) ends the sequence with its outcome. A step sees
the sim time since *it* started (``t`` starts at 0 for every step), so its timeouts count from its own start.

:class:`Monitored` is what the scheduler steps when there are monitors (the task alone otherwise, at no cost).
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from collections.abc import Sequence as Seq
from dataclasses import dataclass
from typing import Any

from robokit import hookimpl
from robokit.components import Behaviour, GoalCheck, SetupContext
from robokit.config import step_names as step_names  # re-exported: where sequences have always found it
from robokit.config.sections import Section
from robokit.errors import PluginError
from robokit.process.crash import describe, where_raised


@dataclass
class Member:
    """A behaviour inside a composition: its name, instance, period in ticks and origin (for error messages)."""

    name: str
    type: str
    behaviour: Any
    period: int
    origin: str


def _call(member: Member, role: str, what: str, fn: Any, *args: Any) -> Any:
    try:
        return fn(*args)
    except PluginError:
        raise
    except Exception as exc:
        where = where_raised(exc)
        raise PluginError(f"{role} {member.name!r} ({member.origin}) raised during {what}: {describe(exc)}"
                          + (f" (at {where})" if where else ""), type_name=member.type) from exc


class Monitored:
    """The task plus its monitors, stepped as one behaviour by the scheduler (every tick; each at its own rate).

    ``outcome`` is the task's: the run ends when the task ends, whatever the monitors are doing.
    """

    open_ended = False

    def __init__(self, task: Member | None, monitors: Seq[Member], clock: Any) -> None:
        self.task, self.monitors, self.clock = task, list(monitors), clock
        self.open_ended = bool(getattr(task.behaviour, "open_ended", False)) if task else True

    @property
    def outcome(self) -> Any:
        """The task's outcome (None while it runs; a config with only monitors never ends by itself)."""
        return self.task.behaviour.outcome if self.task is not None else None

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Step the task (if due), then each running monitor (if due); only the task's commands go out."""
        k = self.clock.tick
        commands = None
        task = self.task
        if task is not None and k % task.period == 0:
            commands = task.behaviour.step(readings, t)
        for m in self.monitors:
            if m.behaviour.outcome is None and k % m.period == 0:
                sent = _call(m, "monitor", "step", m.behaviour.step, readings, t)
                if sent:
                    raise PluginError(f"monitor {m.name!r} ({m.origin}) sent commands to {', '.join(sent)}: monitors "
                                      "observe; only the task ([behaviour]) commands actuators", type_name=m.type)
        return commands

    def results(self) -> dict[str, Any]:
        """Every monitor's outcome, reason and own result, by name."""
        out: dict[str, Any] = {}
        for m in self.monitors:
            outcome = m.behaviour.outcome
            try:
                own = dict(m.behaviour.result())
            except Exception as exc:  # noqa: BLE001 - the run's result must survive a faulty monitor
                own = {"result_error": f"{type(exc).__name__}: {exc}"}
            out[m.name] = {"type": m.type, "outcome": outcome.status if outcome else "running",
                           "reason": outcome.reason if outcome else "", **own}
        return out


class SequenceConfig(Section):
    """``[behaviour]`` with ``type = "sequence"``: the steps are ``[[behaviour.steps]]`` tables (read by the core).

    A light schema (no options): building the simulation, which imports this module, imports no pydantic."""


class Sequence(Behaviour):
    """Runs behaviours one after another: each starts when the previous one succeeded."""

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self.steps: list[Member] = []
        self.index = 0
        self.started_at = 0.0
        self.ended: list[dict[str, Any]] = []

    def add_steps(self, steps: Seq[Member]) -> None:
        """Give the sequence its steps (built and set up by the simulation from ``[[behaviour.steps]]``)."""
        self.steps = list(steps)

    def setup(self, ctx: SetupContext) -> None:
        super().setup(ctx)
        self.clock = ctx.world
        self._trace = ctx.trace
        if self.steps:
            self._trace("step_start", step=self.steps[0].name, index=0, type=self.steps[0].type)

    @property
    def current(self) -> Member | None:
        """The step running now (None when the sequence has ended)."""
        return self.steps[self.index] if self.index < len(self.steps) and self.outcome is None else None

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Step the current step with its own time (``t`` minus its start); move on when it succeeds."""
        member = self.current
        if member is None:
            return None
        commands = None
        local = t - self.started_at
        if round(local / self.clock.time_step) % member.period == 0:
            commands = _call(member, "sequence step", "step", member.behaviour.step, readings, local)
        outcome = member.behaviour.outcome
        if outcome is not None:
            self._end_step(member, outcome, t)
        return commands

    def _end_step(self, member: Member, outcome: Any, t: float) -> None:
        self.ended.append({"name": member.name, "type": member.type, "outcome": outcome.status,
                           "reason": outcome.reason, "started_at": round(self.started_at, 6),
                           "sim_time": round(t - self.started_at, 6)})
        self._trace("step_end", step=member.name, index=self.index, outcome=outcome.status, reason=outcome.reason)
        if outcome.status != "succeeded":
            self.finish(outcome.status, f"step {self.index + 1} {member.name!r} ({member.type}) {outcome.status}: "
                                        f"{outcome.reason}")
            return
        self.index += 1
        self.started_at = t + self.clock.time_step  # the next step's first step is the next tick
        if self.index == len(self.steps):
            self.finish("succeeded", f"all {len(self.steps)} steps succeeded")
        else:
            nxt = self.steps[self.index]
            self._trace("step_start", step=nxt.name, index=self.index, type=nxt.type)

    def check_goal(self, world: Any) -> GoalCheck | None:
        """Every step's own goal (those that state one), evaluated at the end: met only if all are."""
        checks = []
        for member in self.steps[: self.index + 1]:
            hook = getattr(member.behaviour, "check_goal", None)
            check = _call(member, "sequence step", "check_goal", hook, world) if hook else None
            if check is not None:
                checks.append((member.name, check))
        if not checks:
            return None
        missed = [f"{name}: {c.reason}" for name, c in checks if not c.met]
        details = {name: {"met": c.met, "reason": c.reason, **dict(c.details)} for name, c in checks}
        reason = "; ".join(missed) if missed else "; ".join(f"{name}: {c.reason}" for name, c in checks)
        return GoalCheck(not missed, reason, {"steps": details})

    def result(self) -> dict[str, Any]:
        """Per step: name, type, outcome, reason, start and duration (sim s) and the step's own result."""
        out = []
        for i, member in enumerate(self.steps):
            record = self.ended[i] if i < len(self.ended) else {"name": member.name, "type": member.type,
                                                                   "outcome": "running" if i == self.index
                                                                   else "not started", "reason": ""}
            try:
                own = dict(member.behaviour.result()) if i <= self.index else {}
            except Exception as exc:  # noqa: BLE001
                own = {"result_error": f"{type(exc).__name__}: {exc}"}
            out.append({**record, "result": own})
        return {"steps_completed": sum(1 for r in self.ended if r["outcome"] == "succeeded"), "steps": out}

    def close(self) -> None:
        for member in self.steps:
            try:
                member.behaviour.close()
            except Exception:  # noqa: BLE001, S110 - closing must reach every step
                pass


# ---------------------------------------------------------------------------------------------- graph
def _ident(text: str) -> str:
    return re.sub(r"\W", "_", text)


def machine_lines(cls: type, prefix: str, indent: str) -> list[str]:
    """A behaviour class's machine as Mermaid state lines with ids prefixed (one plain state if it has none)."""
    states = getattr(cls, "STATES", None)
    if not (isinstance(states, type) and issubclass(states, enum.Enum)):
        return [f"{indent}state \"{cls.__name__}\" as {prefix}run"]
    lines = [f"{indent}[*] --> {prefix}{cls.INITIAL.name}"]  # type: ignore[attr-defined]
    for tr in getattr(cls, "TRANSITIONS", []):
        sources = tr["source"] if isinstance(tr["source"], list) else [tr["source"]]
        if sources == ["*"]:
            sources = [s.name for s in states]
        for src in sources:
            lines.append(f"{indent}{prefix}{src} --> {prefix}{tr['dest']}: {tr['trigger']}")
    labels = [f"{indent}state \"{s.name}\" as {prefix}{s.name}" for s in states]
    return labels + lines


def config_mermaid(cfg: Any, plugins: Any) -> str:
    """What a config composes, as a Mermaid ``stateDiagram-v2``: the task (a sequence's steps in order, each with
    its own machine inside) and, in a concurrent region, every monitor."""
    lines = ["stateDiagram-v2", "  direction LR"]
    task = cfg.behaviour
    lines.append(f"  state \"run: {cfg.source}\" as run {{")
    if task is None:
        lines.append("    state \"no task: runs for max_time\" as idle")
    elif task.children:
        lines.append(f"    state \"task: sequence of {len(task.children)}\" as task {{")
        previous = "[*]"
        for i, child in enumerate(task.children):
            sid = f"s{i + 1}"
            cls = plugins.get("behaviour", child.type).cls
            lines.append(f"      state \"{i + 1}. {child.name} ({child.type})\" as {sid} {{")
            lines += machine_lines(cls, f"{sid}_", "        ")
            lines.append("      }")
            lines.append(f"      {previous} --> {sid}" + (": succeeded" if i else ""))
            previous = sid
        lines.append(f"      {previous} --> [*]: succeeded")
        lines.append("    }")
    else:
        cls = plugins.get("behaviour", task.type).cls
        lines.append(f"    state \"task: {task.type}\" as task {{")
        lines += machine_lines(cls, "t_", "      ")
        lines.append("    }")
    for spec in getattr(cfg, "monitors", ()):
        cls = plugins.get("behaviour", spec.type).cls
        mid = f"m_{_ident(spec.name)}"
        lines.append("    --")
        lines.append(f"    state \"monitor {spec.name} ({spec.type})\" as {mid} {{")
        lines += machine_lines(cls, f"{mid}_", "      ")
        lines.append("    }")
    lines.append("  }")
    return "\n".join(lines) + "\n"


@hookimpl
def robokit_register_behaviours(register: Any) -> None:
    register("sequence", Sequence, SequenceConfig)
