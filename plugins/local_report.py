"""``local`` reporter: keep every run's result as ``<dir>/<run_id>.json``.

Written atomically (temporary file + rename), never overwritten.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Delivery, Reporter
from robokit.config import Schema
from robokit.reporting import write_json_atomic

__all__ = ["LocalReportConfig", "LocalReporter", "write_json_atomic"]


class LocalReportConfig(Schema):
    """``dir``: folder for result files, relative to the working directory."""

    dir: str = Field("results", min_length=1)


class LocalReporter(Reporter):
    """Writes the result to results/<run_id>.json atomically; never overwrites an earlier result."""

    def report(self, payload: dict[str, Any]) -> Delivery:
        folder = Path(self.config.dir if self.config else "results")
        path = folder / f"{payload['run_id']}.json"
        try:
            write_json_atomic(path, payload)
        except OSError as exc:
            return Delivery(False, None, f"could not write {path}: {exc}")
        return Delivery(True, str(path), f"result saved to {path}")


@hookimpl
def robokit_register_reporters(register):  # type: ignore[no-untyped-def]
    register("local", LocalReporter, LocalReportConfig)
