"""Suite-wide switches.

``ROBOKIT_NO_SKIP=1`` (set by ``.ci/run``): a skipped test or module is a failure, not a quiet pass. Locally a test
may skip when a browser, an extra (``pytest.importorskip``) or a tool (xvfb, ffmpeg) is missing; in CI all of them are
installed, so a skip there means a broken install that would otherwise leave CI green. A test whose skip depends on
the machine in a way CI cannot change (running as root, say) carries ``@pytest.mark.skip_allowed("why")``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import pytest

NO_SKIP = "ROBOKIT_NO_SKIP"


def strict() -> bool:
    """True when skips must fail (``ROBOKIT_NO_SKIP`` set to anything but empty or ``0``)."""
    return os.environ.get(NO_SKIP, "") not in ("", "0")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "skip_allowed(reason): this test may skip even with ROBOKIT_NO_SKIP=1")


def _reason(longrepr: Any) -> str:
    text = str(longrepr[2]) if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    return text.removeprefix("Skipped: ")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    outcome = yield
    report = outcome.get_result()
    if not (strict() and report.skipped) or hasattr(report, "wasxfail"):
        return
    if item.get_closest_marker("skip_allowed") is not None:
        return
    report.outcome = "failed"
    report.longrepr = f"{NO_SKIP}=1: this test skipped ({_reason(report.longrepr)}); in CI a skip is a failure"


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector: pytest.Collector) -> Iterator[None]:
    outcome = yield
    report = outcome.get_result()
    if strict() and report.skipped:
        report.outcome = "failed"
        report.longrepr = (f"{NO_SKIP}=1: {collector.nodeid or 'a module'} skipped at collection "
                           f"({_reason(report.longrepr)}); in CI a skip is a failure")
