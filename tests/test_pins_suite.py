"""The suite's own machinery: ROBOKIT_NO_SKIP turns skips into failures; .ci/run switches it on and runs the default
tier a second time in random order."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SAMPLE = '''
import pytest

def test_runs():
    assert 1 + 1 == 2

@pytest.mark.skipif(True, reason="no browser here")
def test_needs_a_browser():
    pass

def test_needs_a_tool():
    pytest.skip("ffprobe missing")

@pytest.mark.skip_allowed("root ignores permissions")
def test_may_skip():
    pytest.skip("running as root")

@pytest.mark.xfail(reason="known bug", strict=True)
def test_known_bug():
    assert False
'''

EXTRA = '''
import pytest
pytest.importorskip("robokit_no_such_extra_module")

def test_never_collected():
    pass
'''


def run_sample(tmp_path: Path, strict: str | None) -> tuple[int, dict[str, str], str]:
    """Run the sample tests with the suite's conftest; (exit code, test -> outcome from JUnit XML, output)."""
    shutil.copy(ROOT / "tests" / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_sample.py").write_text(SAMPLE, encoding="utf-8")
    (tmp_path / "test_extra.py").write_text(EXTRA, encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "ROBOKIT_NO_SKIP"}
    env["PYTEST_DISABLE_PLUGIN_AUTOLOAD"] = "1"  # only the conftest: fast, and nothing else can change outcomes
    if strict is not None:
        env["ROBOKIT_NO_SKIP"] = strict
    xml = tmp_path / "junit.xml"
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "addopts=", f"--junitxml={xml}",
           "--continue-on-collection-errors",
           str(tmp_path / "test_sample.py"), str(tmp_path / "test_extra.py")]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    got = {}
    for case in ET.parse(xml).getroot().iter("testcase"):
        kinds = [child.tag for child in case if child.tag in ("skipped", "failure", "error")]
        name = case.get("name") or case.get("classname", "")
        got[name] = kinds[0] if kinds else "passed"
        if kinds == ["skipped"] and (case.find("skipped").get("type") or "") == "pytest.xfail":  # type: ignore[union-attr]
            got[name] = "xfail"
    return proc.returncode, got, proc.stdout + xml.read_text(encoding="utf-8")


def test_without_the_switch_skips_stay_skips(tmp_path: Path) -> None:
    code, got, out = run_sample(tmp_path, None)
    assert code == 0, out
    assert got["test_runs"] == "passed" and got["test_known_bug"] == "xfail"
    assert got["test_needs_a_browser"] == got["test_needs_a_tool"] == got["test_may_skip"] == "skipped"
    summary = [ln for ln in out.splitlines() if " passed" in ln][-1]
    assert "4 skipped" in summary  # three tests and the module that needs a missing extra


@pytest.mark.parametrize("value", ["1", "yes"])
def test_with_the_switch_every_skip_fails_except_the_allowed_one(tmp_path: Path, value: str) -> None:
    code, got, out = run_sample(tmp_path, value)
    assert code == 1, out
    assert got["test_runs"] == "passed" and got["test_known_bug"] == "xfail"  # an xfail is not a skip
    assert got["test_needs_a_browser"] == "error"  # skipif acts in setup: a failed setup is an error
    assert got["test_needs_a_tool"] == "failure"
    assert got["test_may_skip"] == "skipped"
    assert got["test_extra"] == "error"  # the module-level importorskip: a collection error
    assert "ROBOKIT_NO_SKIP=1: this test skipped (no browser here)" in out
    assert "robokit_no_such_extra_module" in out
    last = [ln for ln in out.splitlines() if " passed" in ln][-1]
    assert "1 failed" in last and "1 skipped" in last and "2 errors" in last


def test_the_switch_set_to_0_is_off(tmp_path: Path) -> None:
    assert run_sample(tmp_path, "0")[0] == 0


def ci_lines() -> list[str]:
    text = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    return [ln.split("#")[0].strip() for ln in text.splitlines() if ln.split("#")[0].strip()]


def test_ci_turns_skips_into_failures_and_runs_the_default_tier_in_random_order() -> None:
    lines = ci_lines()
    assert "export ROBOKIT_NO_SKIP=1" in lines
    at = lines.index("export ROBOKIT_NO_SKIP=1")
    runs = [ln for ln in lines if ln.startswith("python -m pytest")]
    assert all(lines.index(ln) > at for ln in runs)  # set before any test runs
    shuffled = [ln for ln in runs if "-p randomly" in ln]
    assert shuffled and all("-m slow" not in ln for ln in shuffled)  # the default tier, once more, shuffled
    assert any("-m slow" in ln for ln in runs)
