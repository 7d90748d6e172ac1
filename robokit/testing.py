"""What tests and plugin authors use: build a simulation from a config file or dict, step it tick by tick.

Example::

    from robokit.testing import make_sim

    def test_box_falls():
        with make_sim({"bodies": {"box": {"shape": "box", "position": [0, 0, 1]}}}) as sim:
            sim.step(240)
            assert sim.world.pose("box")[0][2] < 0.1

The pytest plugin (registered automatically when robokit is installed) provides the ``sim_factory`` fixture, which
closes every simulation it built at the end of the test. Conformance checks for plugin types are
:func:`check_sensor`, :func:`check_actuator` and :func:`check_behaviour`.

Behaviours can also be tested with no physics at all: :class:`ScriptedRun` steps one with readings you script and
records the commands and states it produces (see ``docs/behaviours.md``). :func:`lint_paths` is the static check
that plugin code reads no wall clock, never sleeps and draws from no global random generator.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from robokit.core.simulation import Simulation, build

PLANE: dict[str, Any] = {"urdf": "plane.urdf", "position": [0, 0, 0]}
"""A ground plane body, for test configs: ``{"bodies": {"plane": PLANE}}``."""


def make_sim(
    config: str | Path | dict[str, Any],
    *,
    seed: int | None = None,
    extra_plugins: Iterable[object] = (),
    overrides: dict[str, Any] | None = None,
    base_dir: str | Path | None = None,
) -> Simulation:
    """Build a DIRECT-mode simulation from a TOML path or a config dict (as TOML would parse it).

    Args:
        config: Path to a TOML file, or a dict with the same sections.
        seed: Override ``world.seed``.
        extra_plugins: Plugin objects/modules to register besides the installed entry points.
        overrides: Dotted keys to set before validation, e.g. ``{"world.max_time": 5}``.
        base_dir: Folder relative URDF paths in a dict config resolve against (default: cwd).
    """
    return build(config, extra_plugins=tuple(extra_plugins), overrides=overrides, gui=False, seed=seed,
                 base_dir=base_dir)


def transitions(sim: Simulation, machine: str | None = None) -> list[tuple[str, str, str]]:
    """The ``(trigger, from, to)`` state transitions recorded so far, optionally of one machine."""
    return [
        (r["trigger"], r["source_state"], r["dest_state"])
        for r in sim.trace
        if r["kind"] == "transition" and (machine is None or r.get("machine") == machine)
    ]


def states_visited(sim: Simulation, machine: str | None = None) -> list[str]:
    """The sequence of states entered (after the initial one), optionally of one machine."""
    return [to for _, _, to in transitions(sim, machine)]


def run_until(sim: Simulation, predicate: Callable[[Simulation], bool], max_ticks: int) -> bool:
    """Step ``sim`` until ``predicate(sim)`` holds; False if ``max_ticks`` ran out first."""
    return sim.run_until(predicate, max_ticks)


def edited_config(source: str | Path, folder: str | Path, old: str, new: str, *, name: str = "edited.toml") -> Path:
    """Write a copy of a config file with ``old`` replaced by ``new`` (which must occur) into ``folder``.

    For testing config errors against a real, shipped config: ``edited_config(CONFIG, tmp_path, 'a = 1', 'a = -1')``.
    """
    text = Path(source).read_text(encoding="utf-8")
    if old not in text:
        raise AssertionError(f"{old!r} does not occur in {source}")
    path = Path(folder) / name
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def validate_error(config: str | Path) -> str:
    """Run ``robokit validate`` on a config that must be rejected and return its error line.

    Asserts what every config error must be: exit code 2, exactly one line on stderr naming the file, nothing on
    stdout, no traceback.
    """
    import contextlib
    import io

    from robokit.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["validate", str(config)])
    lines = err.getvalue().strip().splitlines()
    assert code == 2, f"exit code {code}, expected 2: {err.getvalue()}"
    assert out.getvalue() == "" and "Traceback" not in err.getvalue(), err.getvalue()
    assert len(lines) == 1, f"expected one line, got: {err.getvalue()}"
    assert lines[0].startswith(f"robokit: error: {config}: "), lines[0]
    return lines[0]


# Conformance checks for plugin types (see robokit.checks.conformance for what they verify).
from robokit.checks.behaviour_conformance import BehaviourReport, check_behaviour  # noqa: E402
from robokit.checks.conformance import (  # noqa: E402
    ConformanceError,
    ConformanceReport,
    check_actuator,
    check_sensor,
    first_difference,
)
from robokit.checks.lint import Finding, lint_paths, lint_source  # noqa: E402
from robokit.checks.scripted import ScriptedRun, ScriptedWorld, StandIn  # noqa: E402

__all__ = [
    "PLANE", "BehaviourReport", "ConformanceError", "ConformanceReport", "Finding", "ScriptedRun", "ScriptedWorld",
    "StandIn", "check_actuator", "check_behaviour", "check_sensor", "first_difference", "lint_paths", "lint_source",
    "make_sim", "run_until", "states_visited", "transitions",
]
