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

_call = call


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
