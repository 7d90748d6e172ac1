"""Checks made before the first tick that belong to no single component (``robokit validate`` runs them).

Components and behaviours add their own through ``preflight(ctx)`` (see :mod:`robokit.components`); the
Simulation gathers everything in :meth:`robokit.core.simulation.Simulation.preflight`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from robokit.errors import ConfigError

if TYPE_CHECKING:
    from robokit.core.world import World

OVERLAP_TOLERANCE = 0.005
"""Metres of interpenetration two bodies may have at spawn (resting contact is about zero)."""


def is_static(world: World, name: str) -> bool:
    """True for bodies that never move: zero base mass (static primitives, fixed-base URDFs)."""
    return bool(world.mass(name) == 0.0)


def overlapping_bodies(world: World, keys: Mapping[str, str],
                       tolerance: float = OVERLAP_TOLERANCE) -> list[ConfigError]:
    """One problem per pair of bodies that interpenetrate by more than ``tolerance`` metres as spawned.

    Two static bodies may overlap (walls meeting at a corner); a body that moves must not start inside another:
    the solver would throw it out at the first step.
    """
    names = world.body_names
    static = {n: is_static(world, n) for n in names}
    problems = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if static[a] and static[b]:
                continue
            depth = world.penetration(world.body(a), world.body(b))
            if depth > tolerance:
                key = keys.get(b, f"bodies.{b}")
                problems.append(ConfigError(f"{b!r} is spawned overlapping {a!r} ({keys.get(a, a)}) by "
                                            f"{depth * 1000:.0f} mm; move one of them", key=key))
    return problems


# ---------------------------------------------------------------------------------------------- composition
def commanded(behaviour: Any) -> set[str] | None:
    """The actuators a behaviour sends commands to, from its type's ``COMMANDS`` (the config fields naming them);
    a composite's are its children's. None when unknown (a type that does not declare them)."""
    children = getattr(behaviour, "children", None)
    if isinstance(children, list) and hasattr(behaviour, "CHILDREN_KEY"):
        out: set[str] = set()
        for member in children:
            out |= commanded(member.behaviour) or set()
        return out
    fields = getattr(type(behaviour), "COMMANDS", None)
    if fields is None:
        return None
    names = (getattr(behaviour.config, f, None) for f in fields)
    return {n for n in names if isinstance(n, str) and n}


def can_succeed(behaviour: Any) -> bool:
    """False when the behaviour can never end ``succeeded`` (its ``can_succeed()`` says so: a guard, an endless
    record); a composite by its rule. True when unknown."""
    children = getattr(behaviour, "children", None)
    kind = type(behaviour).__name__
    if isinstance(children, list) and hasattr(behaviour, "CHILDREN_KEY"):
        able = [can_succeed(m.behaviour) for m in children]
        if kind == "Fallback":
            return any(able)
        if kind == "Parallel" and behaviour.config.success == "one":
            return any(able)
        return all(able)
    hook = getattr(behaviour, "can_succeed", None)
    return bool(hook()) if callable(hook) else True


def composition_problems(specs: Sequence[Any], instances: Mapping[str, Any]) -> list[ConfigError]:
    """What a composition would fail on at run time, found before it runs: two children of a ``parallel`` that
    command one actuator (they would in the same tick), a monitor that commands an actuator, and a ``parallel``
    whose success policy no run can meet (``success = "all"`` with a child that never succeeds, or ``"one"`` with
    none that can). ``specs``: every behaviour section (task tree, monitors, recoveries); ``instances`` by key."""
    problems = []
    for spec in specs:
        comp = instances.get(spec.key)
        if comp is None:
            continue
        if spec.kind == "behaviour" and spec.key.startswith("monitors."):
            sent = commanded(comp)
            if sent:
                problems.append(ConfigError(
                    f"a monitor observes, and type {spec.type!r} commands {', '.join(sorted(sent))}: make it the "
                    "task ([behaviour]) or a child of a parallel", key=spec.key))
        if spec.type != "parallel" or not spec.children:
            continue
        owners: dict[str, str] = {}
        for child_spec, member in zip(spec.children, comp.children, strict=False):
            for name in sorted(commanded(member.behaviour) or ()):
                if name in owners:
                    problems.append(ConfigError(
                        f"{owners[name]!r} and {child_spec.name!r} both command actuator {name!r}: children of a "
                        "parallel are stepped in the same tick, and an actuator takes one command", key=child_spec.key))
                owners.setdefault(name, child_spec.name)
        never = [c.name for c, m in zip(spec.children, comp.children, strict=False) if not can_succeed(m.behaviour)]
        if never and (spec.params.success == "all" or len(never) == len(spec.children)):
            problems.append(ConfigError(
                f"success = {spec.params.success!r} can never be met: {', '.join(repr(n) for n in never)} never "
                "succeed(s) (a guard, or a record with duration 0); use success = \"one\", or give the record a "
                "duration", key=f"{spec.key}.success"))
    return problems
