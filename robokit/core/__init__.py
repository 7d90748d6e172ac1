"""The loop: one World (the physics), one TickScheduler, and the Simulation that wires configured components to them.

Lives here: ``world`` (the World: bodies, joints, links, the sim clock, the run's generator), ``scheduler`` (the
fixed-step tick loop), ``simulation`` (a config's components built and stepped), ``compose`` (monitors beside
the task, monitors that act, ``robokit graph`` of a config), ``composites`` and ``composite_base`` (sequence,
fallback, retry, timeout, parallel), ``result`` (the RunResult), ``preflight``, ``reading_check``, ``walltime``
and ``gui`` (real-time pacing).

May import: ``robokit.errors``, ``robokit.components``, ``robokit.msgs``, ``robokit.process``, ``robokit.config``
and ``robokit.plugin_api``. Never ``report``, ``record``, ``sweep``, ``server``, ``gym``, ``checks`` or the CLI.
"""
