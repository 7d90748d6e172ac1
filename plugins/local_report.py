"""``local`` reporter: keep every run's result as ``<dir>/<run_id>/result.json``, in the run's record folder.

Written atomically (temporary file + rename), never overwritten. The folder also holds the run record
(``trace.jsonl``, ``poses.npz``, ``frames/``: see ``docs/records.md``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robokit import hookimpl
from robokit.components import Delivery, Reporter
from robokit.config.sections import Section, setting
from robokit.report.reporting import write_json_atomic

__all__ = ["LocalReportConfig", "LocalReporter", "write_json_atomic"]


class LocalReportConfig(Section):
    """``dir``: folder for result files, relative to the working directory.

    A light schema (:mod:`robokit.config.sections`): every run gets this reporter, and validating it imports no
    pydantic.
    """

    dir: str = setting("results", min_length=1)


class LocalReporter(Reporter):
    """Writes the result to results/<run_id>/result.json atomically; never overwrites an earlier result."""

    def report(self, payload: dict[str, Any]) -> Delivery:
        folder = Path(self.config.dir if self.config else "results")
        path = folder / str(payload["run_id"]) / "result.json"
        if path.exists():
            return Delivery(False, None, f"not written: {path} already exists")
        try:
            write_json_atomic(path, payload)
        except OSError as exc:
            return Delivery(False, None, f"could not write {path}: {exc}")
        return Delivery(True, str(path), f"result saved to {path}")


@hookimpl
def robokit_register_reporters(register):  # type: ignore[no-untyped-def]
    register("local", LocalReporter, LocalReportConfig)
