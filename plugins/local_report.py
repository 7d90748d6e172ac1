"""``local`` reporter: keep every run's result as ``<dir>/<run_id>.json``, written atomically, never overwritten."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from pydantic import Field

from robokit import hookimpl
from robokit.components import Delivery, Reporter
from robokit.config import Schema


class LocalReportConfig(Schema):
    """``dir``: folder for result files, relative to the working directory."""

    dir: str = Field("results", min_length=1)


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to ``path`` through a temporary file in the same folder and an atomic rename.

    Raises:
        FileExistsError: ``path`` already exists (results are never overwritten).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists():
        raise FileExistsError(f"{path} already exists")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2, sort_keys=False)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


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
