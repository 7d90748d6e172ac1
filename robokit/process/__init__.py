"""Process plumbing every command shares: signal handling (``interrupts``), one-line crash reports (``crash``) and
capturing pybullet's C-level output (``quiet``).

May import: ``robokit.errors`` only. Everything else may import this room.
"""
