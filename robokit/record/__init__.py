"""Run records and what looks at them: the recorder (a loop monitor), and readers for video, plots and pages.

The record format is versioned (:data:`RECORD_SCHEMA`) and documented in ``docs/records.md``. Importing this
package imports neither pybullet nor matplotlib; the commands import what they need.
"""

from robokit.record.format import RECORD_SCHEMA, RunRecord, find_run

__all__ = ["RECORD_SCHEMA", "RunRecord", "find_run"]
