"""The reporting property files' fixtures (a pytest plugin: ``pytest_plugins = ["report_props"]``): one loopback
course server per test and new empty folders for outboxes and run folders."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from report_server import CourseServer


@pytest.fixture
def server() -> Iterator[CourseServer]:
    """A loopback course server that records every request it answers."""
    srv = CourseServer().start()
    yield srv
    srv.stop()


@pytest.fixture
def folders(tmp_path: Path) -> Iterator[Callable[[], Path]]:
    """New empty folders, in RAM where the machine has /dev/shm (the outbox fsyncs each write: the files are real
    files all the same), else under ``tmp_path``."""
    base = Path("/dev/shm") if Path("/dev/shm").is_dir() else tmp_path
    made: list[str] = []

    def new() -> Path:
        made.append(tempfile.mkdtemp(prefix="robokit-report-", dir=base))
        return Path(made[-1])

    yield new
    for folder in made:
        shutil.rmtree(folder, ignore_errors=True)
