"""Suite-wide switches.

``ROBOKIT_NO_SKIP=1`` (set by ``.ci/run``): a skipped test or module is a failure, not a quiet pass. Locally a test
may skip when a browser, an extra (``pytest.importorskip``) or a tool (xvfb, ffmpeg) is missing; in CI all of them are
installed, so a skip there means a broken install that would otherwise leave CI green. A test whose skip depends on
the machine in a way CI cannot change (running as root, say) carries ``@pytest.mark.skip_allowed("why")``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from typing import Any

import pytest

NO_SKIP = "ROBOKIT_NO_SKIP"


def strict() -> bool:
    """True when skips must fail (``ROBOKIT_NO_SKIP`` set to anything but empty or ``0``)."""
    return os.environ.get(NO_SKIP, "") not in ("", "0")


def pytest_configure(config: pytest.Config) -> None:
    # the remembered entry points (robokit.plugin_api.entry_points) of test runs stay out of the user's own cache
    os.environ.setdefault("ROBOKIT_CACHE_DIR", os.path.join(tempfile.gettempdir(), f"robokit-test-cache-{os.getuid()}"))
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


@pytest.fixture
def virtual_display() -> Iterator[dict[str, str]]:
    """A virtual X display of the test's own: an environment whose ``DISPLAY`` names a fresh Xvfb server.

    Xvfb picks a free display number itself (``-displayfd``) and is stopped when the test ends. Tests start the GUI
    program directly in this environment, not under ``xvfb-run``: a signal sent to robokit then reaches robokit alone,
    and the exit code is robokit's (``xvfb-run`` answers 5 when its own clean-up races the program's exit)."""
    yield from xvfb_display()


@pytest.fixture(scope="module")
def module_display() -> Iterator[dict[str, str]]:
    """:func:`virtual_display` shared by a module's tests: for windows opened inside the test process, whose
    connection to the X server lasts as long as the process (the server must outlive them)."""
    yield from xvfb_display()


def xvfb_display() -> Iterator[dict[str, str]]:
    """A fresh Xvfb server for as long as the generator runs: the environment naming it."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("no virtual display: install xvfb (apt-get install xvfb)")
    read_end, write_end = os.pipe()
    server = subprocess.Popen([xvfb, "-displayfd", str(write_end), "-screen", "0", "640x480x24", "-nolisten", "tcp"],
                              pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as announced:
        number = announced.readline().strip()  # "" if Xvfb died before choosing a display
    try:
        if not number.isdigit():
            pytest.fail(f"Xvfb did not start (exit code {server.poll()})")
        yield {**os.environ, "DISPLAY": f":{number}"}
    finally:
        server.terminate()
        server.wait(timeout=30)
