"""State-machine behaviours on top of ``transitions``.

A machine behaviour declares its states, transitions and per-state timeouts as data at the top of its module::

    class Phase(enum.Enum):
        APPROACH = "approach"
        GRASP = "grasp"
        DONE = "done"

    TRANSITIONS = [
        {"trigger": "arrived", "source": "APPROACH", "dest": "GRASP"},
        {"trigger": "closed", "source": "GRASP", "dest": "DONE"},
    ]

Per-tick work is a direct call of the current state's handler ``do_<state name lower-case>(readings, t)``; a trigger
(:meth:`MachineBehaviour.fire`) is fired only when something changes, because a trigger costs ~10-20 µs and a
physics step ~140 µs. Timeouts count sim seconds (``transitions``' own ``Timeout`` uses a thread timer and is not
used); a config that has a ``timeouts`` table (state name -> sim seconds) overrides the class's ``TIMEOUTS`` state
by state, with no code in the behaviour. Every change of state is written to the run's trace.

The full guide, with a worked example, is ``docs/behaviours.md``.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import Field
from transitions import Machine

from robokit.components import Behaviour, SetupContext
from robokit.config import Schema
from robokit.errors import ConfigError, did_you_mean


class MachineConfig(Schema):
    """Base config schema of a machine behaviour: adds ``timeouts``, a table of state name -> sim seconds.

    Subclass it for your behaviour's own options; the per-state timeouts then work with no code::

        [behaviour]
        type = "my_machine"
        timeouts = { SEARCH = 4.0 }
    """

    timeouts: dict[str, float] = Field(default_factory=dict,
                                       description="state name -> sim seconds (overrides the class's TIMEOUTS)")


class MachineBehaviour(Behaviour):
    """A :class:`~robokit.components.Behaviour` driven by a ``transitions`` machine.

    Class attributes:
        STATES: An Enum of states.
        TRANSITIONS: A list of transition dicts (``trigger``, ``source``, ``dest``, optional ``conditions``).
        INITIAL: The initial state (a member of ``STATES``).
        TIMEOUTS: Sim seconds allowed per state name; :meth:`on_timeout` runs when one is exceeded. The
            config's ``timeouts`` table (if its schema has one, see :class:`MachineConfig`) overrides them.

    Instance attributes:
        timeouts: The timeouts in force: ``TIMEOUTS`` updated with the config's ``timeouts``.
        t: Sim time of the current step, seconds: the world's clock, the same for every behaviour, sequence step,
            sub-machine and monitor. Durations since the machine started: :meth:`elapsed`.
        entered_at: Sim time the current state was entered (the initial state: the machine's first step).
        visited: Every state entered so far, in order, the initial one first.
        phase_times: Sim seconds spent per state name (states left so far).
    """

    STATES: ClassVar[type[enum.Enum]]
    TRANSITIONS: ClassVar[list[dict[str, Any]]] = []
    INITIAL: ClassVar[enum.Enum]
    TIMEOUTS: ClassVar[dict[str, float]] = {}

    state: Any
    trigger: Any  # added by transitions: trigger(name) fires a named trigger

    def __init__(self, name: str, config: Any) -> None:
        super().__init__(name, config)
        self._t = 0.0
        self._clock_started = False
        self.entered_at = 0.0
        self.visited: list[str] = [self.INITIAL.name]
        self._entries = 0  # transitions run so far (self-transitions included): what fire() compares
        self.phase_times: dict[str, float] = {}
        configured = getattr(config, "timeouts", None) or {}
        self.timeouts: dict[str, float] = {**self.TIMEOUTS, **configured}
        self._trace: Any = None
        self._trigger = ""
        self._handlers: dict[str, dict[str, Any]] = {"do": {}, "enter": {}}
        self._named_state: Any = None  # the state whose name is cached in _state_name (read every tick)
        self._state_name = ""
        self.machine = Machine(
            model=self,
            states=self.STATES,
            transitions=self.TRANSITIONS,
            initial=self.INITIAL,
            auto_transitions=False,
            after_state_change="_after_change",
            before_state_change="_before_change",
            model_override=False,
        )

    def setup(self, ctx: SetupContext) -> None:
        """Keep the context and the trace writer; subclasses call ``super().setup(ctx)`` first.

        Raises:
            ConfigError: The config's ``timeouts`` names a state the machine does not have, or is not positive.
        """
        super().setup(ctx)
        self._trace = ctx.trace
        states = [s.name for s in self.STATES]
        for state, seconds in (getattr(self.config, "timeouts", None) or {}).items():
            if state not in states:
                raise ConfigError(f"unknown state {state!r}{did_you_mean(state, states)}; states: "
                                  f"{', '.join(states)}", key=f"timeouts.{state}")
            if not seconds > 0:
                raise ConfigError(f"a timeout is sim seconds > 0, got {seconds!r}", key=f"timeouts.{state}")

    @property
    def state_name(self) -> str:
        """Name of the current state."""
        state = self.state
        if state is not self._named_state:
            self._state_name = state.name if isinstance(state, enum.Enum) else str(state)
            self._named_state = state
        return self._state_name

    def fire(self, trigger: str) -> bool:
        """Fire a trigger (only when something changed); returns True if a transition ran: the state changed, or a
        self-transition left and re-entered it (a retry fired in the very state it retries). False when a
        condition held the transition back."""
        self._trigger = trigger
        before = self._entries
        self.trigger(trigger)
        return self._entries != before

    def _before_change(self) -> None:
        self._from = self.state_name
        self.phase_times[self._from] = self.phase_times.get(self._from, 0.0) + (self.t - self.entered_at)

    def _after_change(self) -> None:
        self._entries += 1
        self.entered_at = self.t
        self.visited.append(self.state_name)
        if self._trace is not None:
            self._trace("transition", machine=self.name, trigger=self._trigger, source_state=self._from,
                        dest_state=self.state_name)

    def handler(self, prefix: str = "do") -> Any:
        """The current state's method ``<prefix>_<state name lower-case>`` or None (looked up once per state; the
        tables are keyed by state name, a string: an ``Enum`` member's hash is a Python-level call)."""
        table = self._handlers.get(prefix)
        if table is None:
            table = self._handlers[prefix] = {}
        name = self.state_name
        try:
            return table[name]
        except KeyError:
            found = table[name] = getattr(self, f"{prefix}_{name.lower()}", None)
            return found

    @property
    def t(self) -> float:
        """Sim time of the current step (the world's clock, seconds)."""
        return self._t

    @t.setter
    def t(self, value: float) -> None:
        # The first time set is when this machine starts: its initial state is entered then, however late that is
        # on the world's clock (a sequence's later step, a sub-machine started by its parent).
        if not self._clock_started:
            self._clock_started = True
            self.entered_at = value
            if self.started_at is None:
                self.started_at = value
        self._t = value

    @property
    def time_in_state(self) -> float:
        """Sim seconds since the current state was entered."""
        return self._t - self.entered_at

    def step(self, readings: Mapping[str, Any], t: float) -> Mapping[str, Any] | None:
        """Check the state's timeout, then call ``do_<state>(readings, t)`` and return its commands."""
        self.t = t
        name = self.state_name
        limit = self.timeouts.get(name)
        if limit is not None and t - self.entered_at > limit:
            self.on_timeout(name)
            if self.outcome is not None:
                return None
        handler = self.handler("do")
        if handler is None:
            return None
        return handler(readings, t)  # type: ignore[no-any-return]

    def on_timeout(self, state: str) -> None:
        """The current state ran longer than its timeout (sim seconds). Default: fail with a reason naming the state.

        Runs inside :meth:`step`, before the state's handler; if it sets an outcome the handler is not called.
        Override it to retry (fire a trigger) instead.
        """
        self.finish("failed", f"timed out in state {state} after {self.timeouts[state]:g} s (sim time)")

    @classmethod
    def mermaid(cls) -> str:
        """The machine as a Mermaid ``stateDiagram-v2`` (no graphviz needed)."""
        from transitions.extensions import GraphMachine

        class _Model:
            pass

        graph = GraphMachine(model=_Model(), states=cls.STATES, transitions=cls.TRANSITIONS, initial=cls.INITIAL,
                             auto_transitions=False, graph_engine="mermaid", title=cls.__name__)
        text = str(graph.get_graph().draw(None))
        keep = [line for line in text.splitlines() if not re.match(r"\s*(classDef|Class)\s", line)]
        return "\n".join(line for line in keep if line.strip()) + "\n"
