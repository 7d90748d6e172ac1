"""Run records and what looks at them: the recorder (a loop monitor), and readers for video, plots and pages.

The record format is versioned (:data:`RECORD_SCHEMA`) and documented in ``docs/records.md``. Importing this
package imports neither pybullet nor matplotlib; the commands import what they need.
"""

from __future__ import annotations

from typing import Any

__all__ = ["RECORD_SCHEMA", "RunRecord", "find_run"]


def __getattr__(name: str) -> Any:
    """The format's names, imported on first use (it needs numpy, which ``robokit --help`` must not pay for)."""
    if name in __all__:
        from robokit.record import format as _format

        return getattr(_format, name)
    raise AttributeError(f"module 'robokit.record' has no attribute {name!r}")
