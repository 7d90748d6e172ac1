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
previous one succeeded; the first step that fails (or is aborted) ends the sequence with its outcome. Every step
sees the world's sim time ``t`` (one clock for the run); its own stopwatch is ``behaviour.elapsed(t)``, so a
``duration`` or ``timeout`` counts from the step's start. The other composites (fallback, retry, timeout, parallel)
are in :mod:`robokit.core.composites`.

:class:`Monitored` is what the scheduler steps when there are monitors (the task alone otherwise, at no cost).
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from collections.abc import Sequence as Seq
from typing import Any

from robokit.config import step_names as step_names  # re-exported: where sequences have always found it
from robokit.core.composites import Member as Member
from robokit.core.composites import Sequence as Sequence
from robokit.core.composites import call
from robokit.errors import PluginError

_call = call  # the old private name


class Monitored:
    """The task plus its monitors, stepped as one behaviour by the scheduler (every tick; each at its own rate).

    ``outcome`` is the task's: the run ends when the task ends, whatever the monitors are doing. A monitor with
    ``action = "abort"`` or ``"recover"`` that ends ``failed`` or ``aborted`` acts in the tick it ends, after every
    monitor due in that tick was stepped, before the actuators run and before the physics step: the task is halted
    (its ``halt(t)``, if any), its commands of that tick are dropped, and every actuator with a
    ``protective_stop(reason)`` is stopped. ``abort`` then ends the task (``aborted``, the monitor's reason);
    ``recover`` steps the named recovery from the next tick until it ends, and the task ends with ``aborted`` (the
    recovery succeeded) or the recovery's ``failed``/``aborted``.

    **Guards keep guarding**: while the recovery runs, a fresh instance of the monitor that pre-empted the task
    (``watchers``, built before the run; its optional ``take_over(previous)`` receives the instance that tripped,
    so a guard keeps its force baseline) watches it, unless the monitor says ``watch_recovery = false``; every other
    monitor goes on as before. One that acts during the recovery halts it, stops the actuators in that tick, and
    the run ends ``aborted``.
    """

    open_ended = False

    def __init__(self, task: Member | None, monitors: Seq[Member], clock: Any,
                 actuators: Mapping[str, Any] | None = None, recoveries: Mapping[str, Member] | None = None,
                 trace: Any = None) -> None:
        self.task, self.monitors, self.clock = task, list(monitors), clock
        self.open_ended = bool(getattr(task.behaviour, "open_ended", False)) if task else True
        self.actuators = dict(actuators or {})
        self.recoveries = dict(recoveries or {})
        self.trace = trace or (lambda kind, **data: None)
        self.fired: tuple[Member, Any, float] | None = None
        """The monitor that acted, its outcome and the sim time it acted at."""
        self.recovery: Member | None = None
        self.watchers: dict[str, Member] = {}
        """Spare instances of the monitors that pre-empt into a recovery and watch it, by monitor name."""
        self.watching: Member | None = None
        self.stopped: tuple[Member, Any, float] | None = None
        """The monitor that stopped the recovery, its outcome and the sim time."""

    @property
    def outcome(self) -> Any:
        """The task's outcome (None while it runs; a config with only monitors never ends by itself)."""
        return self.task.behaviour.outcome if self.task is not None else None

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Step the task or its recovery (if due), then each running monitor (if due); only the task's (or the
        recovery's) commands go out, none in the tick a monitor acts."""
        k = self.clock.tick
        commands = None
        task = self.task
        if self.recovery is not None:
            commands = self._step_recovery(readings, t)
        elif task is not None and k % task.period == 0 and self.fired is None:
            commands = task.behaviour.step(readings, t)
        acting = None
        for m in self.monitors if self.watching is None else [*self.monitors, self.watching]:
            if m.behaviour.outcome is None and k % m.period == 0:
                sent = call(m, "monitor", "step", m.behaviour.step, readings, t)
                if sent:
                    raise PluginError(f"monitor {m.name!r} ({m.origin}) sent commands to {', '.join(sent)}: monitors "
                                      "observe; only the task ([behaviour]) commands actuators", type_name=m.type)
                if acting is None and self._acts(m):
                    acting = m
        if acting is not None:
            if self.recovery is None:
                self._act(acting, t)
            else:
                self._stop_recovery(acting, t)
            return None
        return commands

    def _acts(self, m: Member) -> bool:
        outcome = m.behaviour.outcome
        action = getattr(m.spec, "action", "observe")
        return (outcome is not None and outcome.status != "succeeded" and action != "observe"
                and (self.fired is None or self.recovery is not None)
                and self.task is not None and self.task.behaviour.outcome is None)

    def _act(self, m: Member, t: float) -> None:
        """A monitor acts: halt the task, stop the actuators, then abort or start the recovery (next tick)."""
        assert self.task is not None
        outcome, action = m.behaviour.outcome, m.spec.action
        self.fired = (m, outcome, t)
        halt = getattr(self.task.behaviour, "halt", None)
        if halt is not None:
            call(self.task, "task", "halt", halt, t)
        why = f"monitor {m.name!r} ({m.type}): {outcome.reason}"
        self.stop_actuators(why)
        if action == "abort":
            self.trace("monitor_abort", monitor=m.name, reason=outcome.reason)
            self.task.behaviour.finish("aborted", f"aborted by {why}")
            return
        self.recovery = self.recoveries[m.spec.recovery]
        self.trace("monitor_preempt", monitor=m.name, reason=outcome.reason, recovery=self.recovery.name)
        self.recovery.behaviour.started_at = t + self.clock.time_step  # its first step is the next tick
        self.recovery.start_tick = self.clock.tick + 1
        self.watching = self.watchers.get(m.name)
        if self.watching is not None:
            take_over = getattr(self.watching.behaviour, "take_over", None)
            if take_over is not None:
                call(self.watching, "monitor", "take_over", take_over, m.behaviour)
            self.watching.behaviour.started_at = t + self.clock.time_step
            self.trace("monitor_watch", monitor=m.name, recovery=self.recovery.name)

    def _stop_recovery(self, m: Member, t: float) -> None:
        """A monitor acts while the recovery runs: halt the recovery, stop the actuators, end the run aborted."""
        rec, fired = self.recovery, self.fired
        assert rec is not None and fired is not None and self.task is not None
        outcome = m.behaviour.outcome
        self.stopped = (m, outcome, t)
        halt = getattr(rec.behaviour, "halt", None)
        if halt is not None:
            call(rec, "recovery", "halt", halt, t)
        why = f"monitor {m.name!r} ({m.type}): {outcome.reason}"
        self.stop_actuators(why)
        self.trace("monitor_abort", monitor=m.name, reason=outcome.reason, recovery=rec.name)
        first, first_outcome, at = fired
        self.task.behaviour.finish("aborted", f"pre-empted at t = {at:.3f} s by monitor {first.name!r} ({first.type}): "
                                              f"{first_outcome.reason}; recovery {rec.name!r} aborted by {why}")

    def stop_actuators(self, reason: str) -> list[str]:
        """Bring every actuator that can to a protective stop now; returns their names."""
        stopped = []
        for name, comp in self.actuators.items():
            stop = getattr(comp, "protective_stop", None)
            if stop is not None:
                stop(reason)
                stopped.append(name)
        return stopped

    def _step_recovery(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        rec = self.recovery
        assert rec is not None and self.fired is not None and self.task is not None
        if self.clock.tick < rec.start_tick or (self.clock.tick - rec.start_tick) % rec.period:
            return None
        commands = call(rec, "recovery", "step", rec.behaviour.step, readings, t)
        done = rec.behaviour.outcome
        if done is not None:
            m, outcome, at = self.fired
            status = "aborted" if done.status == "succeeded" else done.status
            self.trace("recovery_end", recovery=rec.name, outcome=done.status, reason=done.reason)
            self.task.behaviour.finish(status, f"pre-empted at t = {at:.3f} s by monitor {m.name!r} ({m.type}): "
                                               f"{outcome.reason}; recovery {rec.name!r} {done.status}: {done.reason}")
        return commands  # type: ignore[no-any-return]

    def results(self) -> dict[str, Any]:
        """Every monitor's outcome, reason, action and own result, by name; the one that acted says when and
        (with a recovery) how the recovery went."""
        out: dict[str, Any] = {}
        for m in self.monitors:
            outcome = m.behaviour.outcome
            out[m.name] = {"type": m.type, "outcome": outcome.status if outcome else "running",
                           "reason": outcome.reason if outcome else "",
                           "action": getattr(m.spec, "action", "observe"), **_own(m)}
            if self.fired is not None and self.fired[0] is m:
                out[m.name]["acted_at"] = round(self.fired[2], 6)
                if self.recovery is not None:
                    out[m.name]["recovery"] = self._recovery_record(self.recovery)
                if self.watching is not None:
                    w = self.watching
                    done = w.behaviour.outcome
                    out[m.name]["watch"] = {"outcome": done.status if done else "running",
                                            "reason": done.reason if done else "", **_own(w)}
        return out

    def _recovery_record(self, rec: Member) -> dict[str, Any]:
        done = rec.behaviour.outcome
        status, reason = (done.status, done.reason) if done else ("running", "")
        if self.stopped is not None:
            m, outcome, at = self.stopped
            status, reason = "halted", f"at t = {at:.3f} s by monitor {m.name!r} ({m.type}): {outcome.reason}"
        return {"name": rec.name, "type": rec.type, "outcome": status, "reason": reason, "result": _own(rec)}


def _own(m: Member) -> dict[str, Any]:
    try:
        return dict(m.behaviour.result())
    except Exception as exc:  # noqa: BLE001 - the run's result must survive a faulty monitor
        return {"result_error": f"{type(exc).__name__}: {exc}"}


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
    """What a config composes, as a Mermaid ``stateDiagram-v2``: the task (composites drawn as nested states with
    their children inside, each child's own machine inside it) and, in concurrent regions, every monitor (with the
    recovery it may pre-empt the task into)."""
    lines = ["stateDiagram-v2", "  direction LR"]
    task = cfg.behaviour
    lines.append(f"  state \"run: {cfg.source}\" as run {{")
    if task is None:
        lines.append("    state \"no task: runs for max_time\" as idle")
    else:
        lines += _node(task, plugins, "task", "task: ", "    ")
    for spec in getattr(cfg, "monitors", ()):
        mid = f"m_{_ident(spec.name)}"
        lines.append("    --")
        action = getattr(spec, "action", "observe")
        label = f"monitor {spec.name} ({spec.type})" + ("" if action == "observe" else f", action {action}")
        lines += _node(spec, plugins, mid, "", "    ", title=label)
        recovery = getattr(cfg, "recoveries", {}).get(getattr(spec, "recovery", None) or "")
        if recovery is not None:
            rid = f"r_{_ident(recovery.name)}"
            lines += _node(recovery, plugins, rid, "", "    ", title=f"recovery {recovery.name} ({recovery.type})")
            lines.append(f"    {mid} --> {rid}: failed or aborted: pre-empt the task")
    lines.append("  }")
    return "\n".join(lines) + "\n"


_EDGE = {"sequence": "succeeded", "fallback": "failed"}


def _node(spec: Any, plugins: Any, sid: str, prefix: str, indent: str, title: str | None = None) -> list[str]:
    """A behaviour section as a Mermaid state: a composite with its children inside, else the type's machine."""
    cls = plugins.get("behaviour", spec.type).cls
    if not spec.children:
        name = title or f"{prefix}{spec.type}"
        return [f"{indent}state \"{name}\" as {sid} {{", *machine_lines(cls, f"{sid}_", indent + "  "), f"{indent}}}"]
    detail = _detail(spec)
    label = title or f"{prefix}{spec.type}{detail} of {len(spec.children)}"
    out = [f"{indent}state \"{label}\" as {sid} {{"]
    inner = indent + "  "
    ids = [f"{sid}_{i + 1}" for i in range(len(spec.children))]
    for i, (child, cid) in enumerate(zip(spec.children, ids, strict=True)):
        if spec.type == "parallel" and i:
            out.append(f"{inner}--")
        if child.children:
            named = f"{child.type}" if child.name == child.type else f"{child.name}: {child.type}"
            label_child = f"{i + 1}. {named}{_detail(child)} of {len(child.children)}"
        else:
            label_child = f"{i + 1}. {child.name} ({child.type})"
        out += _node(child, plugins, cid, "", inner, title=label_child)
    edge = _EDGE.get(spec.type)
    if edge is not None:  # every way out: on to the next child, or the composite ends with this one's outcome
        out.append(f"{inner}[*] --> {ids[0]}")
        for a, b in zip(ids, ids[1:], strict=False):
            out.append(f"{inner}{a} --> {b}: {edge}")
        ends = "failed or aborted" if spec.type == "sequence" else "succeeded"
        out += [f"{inner}{a} --> [*]: {ends}" for a in ids[:-1]]
        out.append(f"{inner}{ids[-1]} --> [*]")
    elif spec.type == "retry":
        out += [f"{inner}[*] --> {ids[0]}", f"{inner}{ids[0]} --> {ids[0]}: failed (a fresh attempt)",
                f"{inner}{ids[0]} --> [*]: succeeded"]
    elif spec.type == "timeout":
        out += [f"{inner}[*] --> {ids[0]}", f"{inner}{ids[0]} --> [*]: ended, or halted after{detail}"]
    out.append(f"{indent}}}")
    return out


def _detail(spec: Any) -> str:
    """A composite's options in a few words (``x3``, ``5 s``, ``success all, failure one``)."""
    p = spec.params
    if spec.type == "retry":
        return f" x{p.attempts}"
    if spec.type == "timeout":
        return f" {p.seconds:g} s"
    if spec.type == "parallel":
        return f" success {p.success}, failure {p.failure}"
    return ""
