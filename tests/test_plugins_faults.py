"""Fault isolation at run time: a third-party plugin that raises ends the run with outcome ``error``.

The reason names the plugin type and its distribution, the partial result is kept and reported (the local
reporter's file), and ``robokit run`` exits with code 3 (documented in ``robokit.cli`` and docs/plugins.md).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from plugin_dists import BROKEN_REPORTER, FAULTY_SENSORS, RAISING_RUN_START, make_dist

from robokit.cli import EXIT_PLUGIN, main
from robokit.core.result import OUTCOME_EXIT_CODES
from robokit.plugin_api.plugins import load_plugins
from robokit.runner import run_config
from robokit.testing import make_sim

SCENE = """
[world]
max_time = 2.0

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [0, 0, 0.5]

[sensors.poses]
type = "body_pose"
rate_hz = 60
"""

READ_FAULT = SCENE + """
[sensors.sonar]
type = "flaky_read"
rate_hz = 60
fail_at_read = 3          # reads at ticks 0 and 4 work, the one at tick 8 raises

[behaviour]
type = "record"
components = ["poses", "sonar"]
rate_hz = 60
duration = 1.0
"""

SETUP_FAULT = SCENE + """
[sensors.sonar]
type = "flaky_setup"

[behaviour]
type = "record"
duration = 1.0
"""


@pytest.fixture
def faulty(tmp_path, monkeypatch):
    """The ``fault-dist 1.0`` distribution on sys.path; the working directory (results/) in tmp_path."""
    make_dist(tmp_path / "site", "fault-dist", "1.0", FAULTY_SENSORS)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def line_of(source: str, text: str) -> int:
    """The line number of ``text`` in a plugin module written by make_dist (which dedents, keeping lines)."""
    return next(i for i, line in enumerate(source.splitlines(), 1) if text in line)


def stored_results(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((folder / "results").glob("*/result.json"))]


def test_sensor_raising_in_read_ends_with_error_keeping_the_partial_result(faulty, capsys):
    config = faulty / "read_fault.toml"
    config.write_text(READ_FAULT)
    trace = faulty / "trace.jsonl"
    assert main(["run", str(config), "--json", "--trace", str(trace)]) == EXIT_PLUGIN == 3
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "error"
    reason = result["reason"]
    assert "sensor 'sonar'" in reason and "type 'flaky_read'" in reason and "fault-dist 1.0" in reason
    assert "raised during read: RuntimeError: sensor bus timeout" in reason
    assert result["ticks"] == 8  # stopped at the failing tick, not at max_time
    # the behaviour's partial result: at tick 8 it recorded the poses, then reading the sonar raised
    assert result["result"]["recorded"] == {"poses": 3, "sonar": 2}
    assert result["result"]["last"]["sonar"] == 2.0
    # reported: the local reporter kept the same run, error and partial result included
    (stored,) = stored_results(faulty)
    assert stored["run_id"] == result["run_id"] and stored["outcome"] == "error"
    assert stored["result"]["recorded"] == {"poses": 3, "sonar": 2}
    # and the trace holds what was read before the fault
    readings = [json.loads(line) for line in trace.read_text().splitlines()]
    assert [r["value"] for r in readings if r.get("component") == "sonar"] == [1.0, 2.0]


def test_sensor_raising_in_setup_ends_with_error_and_is_still_reported(faulty, capsys):
    config = faulty / "setup_fault.toml"
    config.write_text(SETUP_FAULT)
    assert main(["run", str(config)]) == 3
    out = capsys.readouterr().out
    assert out.startswith("outcome: error (sensors.sonar: sensor type 'flaky_setup' (fault-dist 1.0) raised during "
                          "setup: RuntimeError: calibration file missing (at site/fault_dist_")
    assert out.splitlines()[0].endswith(f".py:{line_of(FAULTY_SENSORS, 'calibration file missing')}))")
    assert "result saved to results/" in out
    (stored,) = stored_results(faulty)
    assert stored["outcome"] == "error" and "flaky_setup" in stored["reason"] and "fault-dist 1.0" in stored["reason"]
    assert stored["ticks"] == 0


def test_validate_reports_a_setup_fault_with_exit_code_3(faulty, capsys):
    config = faulty / "setup_fault.toml"
    config.write_text(SETUP_FAULT)
    assert main(["validate", str(config)]) == 3
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "flaky_setup" in err and "fault-dist 1.0" in err


def test_a_raising_run_start_hook_is_an_error_naming_its_plugin(tmp_path, monkeypatch):
    make_dist(tmp_path, "telemetry-dist", "0.2", RAISING_RUN_START, entry_name="telemetry")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "c.toml"
    config.write_text(SCENE + '[behaviour]\ntype = "record"\nduration = 0.1\n')
    from robokit.config import load_config

    plugins = load_plugins()
    out = run_config(load_config(config, plugins), plugins)
    assert out.result.outcome == "error" and out.exit_code == 3
    assert out.result.reason.startswith("plugin telemetry-dist:telemetry raised in robokit_run_start: RuntimeError: "
                                        "telemetry server unreachable (at telemetry_dist_")
    assert out.result.reason.endswith(f".py:{line_of(RAISING_RUN_START, 'telemetry server unreachable')})")
    assert out.stored


def test_a_reporter_that_cannot_be_built_does_not_cost_the_result(tmp_path, monkeypatch, capsys):
    make_dist(tmp_path / "site", "grumpy-dist", "0.9", BROKEN_REPORTER)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "c.toml"
    config.write_text(SCENE + '[behaviour]\ntype = "record"\nduration = 0.1\n[report.grumpy]\n')
    assert main(["run", str(config)]) == 0  # the local reporter still stored it
    out = capsys.readouterr().out
    assert "report[grumpy]: reporter 'grumpy' (grumpy-dist 0.9) failed to build: RuntimeError: no credentials" in out
    (stored,) = stored_results(tmp_path)
    assert stored["outcome"] == "succeeded"


def test_sim_step_raises_plugin_error_naming_type_and_distribution(faulty):
    from robokit.errors import PluginError

    config = faulty / "read_fault.toml"
    config.write_text(READ_FAULT)
    with make_sim(config) as sim:
        sim.step(8)
        with pytest.raises(PluginError) as info:
            sim.step(1)
    assert info.value.type_name == "type 'flaky_read' from fault-dist 1.0"


def test_robokit_run_process_exits_3_promptly_with_the_reason(faulty):
    """The real command in a fresh process: no hang, exit code 3, the reason on the summary line."""
    config = faulty / "read_fault.toml"
    config.write_text(READ_FAULT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(faulty / "site"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", "run", str(config)], cwd=faulty, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 3 == OUTCOME_EXIT_CODES["error"], proc.stderr
    first = proc.stdout.splitlines()[0]
    assert first.startswith("outcome: error (sensor 'sonar' (type 'flaky_read' from fault-dist 1.0) raised during "
                            "read: RuntimeError: sensor bus timeout (at site/fault_dist_")
    assert first.endswith(f".py:{line_of(FAULTY_SENSORS, 'sensor bus timeout')}))")
    assert '  recorded: {"poses": 3, "sonar": 2}' in proc.stdout.splitlines()
    assert "Traceback" not in proc.stderr
