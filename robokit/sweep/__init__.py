"""Many runs of one config: ``robokit sweep``.

A trial is a pure function — config text + overrides + seed -> RunResult — run in a worker that builds its own
World. The pieces are plain functions:

- :mod:`robokit.sweep.spec`: a :class:`SweepSpec` (config, seeds, grid) expanded into :class:`Trial` s with stable
  keys;
- :mod:`robokit.sweep.trial`: :func:`run_trial`, one trial in this process -> one row;
- :mod:`robokit.sweep.engine`: :func:`run_sweep`, validation, resuming, recording, summarising;
- :mod:`robokit.sweep.summary`: per-cell success rate (95 % Wilson interval), median and p95, JUnit, plots;
- backends: :mod:`robokit.sweep.local` (spawn process pool) and :mod:`robokit.sweep.ray_backend` (Ray tasks).

Nothing here imports pybullet, Ray or matplotlib at import time.
"""

from robokit.sweep.engine import SweepOptions, SweepRun, read_trials, run_sweep
from robokit.sweep.spec import SweepSpec, Trial, load_sweep_file, parse_seeds, parse_set
from robokit.sweep.trial import TrialTask, run_trial

__all__ = ["SweepOptions", "SweepRun", "SweepSpec", "Trial", "TrialTask", "load_sweep_file", "parse_seeds",
           "parse_set", "read_trials", "run_sweep", "run_trial"]
