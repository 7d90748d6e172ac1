"""Many runs of one config: ``robokit sweep``.

A trial is a pure function — config text + overrides + seed -> RunResult — run in a worker that builds its own
World. The pieces are plain functions:

- :mod:`robokit.sweep.spec`: a :class:`SweepSpec` (config, seeds, grid) expanded into :class:`Trial` s with stable
  keys;
- :mod:`robokit.sweep.trial`: :func:`run_trial`, one trial in this process -> one row;
- :mod:`robokit.sweep.engine`: :func:`run_sweep`, validation, resuming, recording, summarising;
- :mod:`robokit.sweep.summary`: per-cell success rate (95 % Wilson interval), median and p95, JUnit, plots;
- backends: :mod:`robokit.sweep.local` (spawn process pool) and :mod:`robokit.sweep.ray_backend` (Ray tasks).

Nothing here imports pybullet, Ray or matplotlib at import time; the package's names load on first use.
"""

from __future__ import annotations

from typing import Any

_WHERE = {
    "SweepOptions": "engine", "SweepRun": "engine", "read_trials": "engine", "run_sweep": "engine",
    "SweepSpec": "spec", "Trial": "spec", "load_sweep_file": "spec", "parse_seeds": "spec", "parse_set": "spec",
    "TrialTask": "trial", "run_trial": "trial",
}

__all__ = ["SweepOptions", "SweepRun", "SweepSpec", "Trial", "TrialTask", "load_sweep_file", "parse_seeds",
           "parse_set", "read_trials", "run_sweep", "run_trial"]


def __getattr__(name: str) -> Any:
    """The package's names, imported on first use: ``robokit sweep``'s argument parser (built for every
    ``robokit`` command, ``--help`` included) imports :mod:`robokit.sweep.cli` and must not pay for the engine."""
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'robokit.sweep' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(f"robokit.sweep.{module}"), name)
