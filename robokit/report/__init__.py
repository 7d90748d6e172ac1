"""Getting a RunResult to where it belongs: reporters (local JSON, HTTP), the outbox that keeps what could not be
delivered, ``robokit outbox`` and artifact uploads.

May import: ``robokit.errors``, ``robokit.process``, ``robokit.config``, ``robokit.components`` and
``robokit.core`` (the RunResult). Never ``record``, ``sweep``, ``server``, ``gym``, ``checks`` or the CLI.
"""
