"""Start-up of ``robokit run`` (``benchmarks/startup.py`` measures it): what a trivial run imports, the collector
paused during start-up only, one OpenBLAS thread unless the user says otherwise, and nothing changed for code
that calls :func:`robokit.cli.main` itself."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main

TRIVIAL = """[world]
max_time = 0.1

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0, 0, 0.5]
"""

# The console script's path (main() reading sys.argv). With "watch", run_config is wrapped to look at the collector
# when the run starts (that imports numpy before main() runs: the OpenBLAS setting is then left alone).
CHILD = """
import gc, json, os, sys
seen = {}
if sys.argv[1:] == ["watch"]:
    import robokit.runner as runner
    real = runner.run_config
    def run_config(*args, **kwargs):
        seen["gc_enabled_at_run"] = gc.isenabled()
        seen["frozen_at_run"] = gc.get_freeze_count()
        return real(*args, **kwargs)
    runner.run_config = run_config
from robokit.cli import main
sys.argv = ["robokit", "run", "trivial.toml", "--quiet"]
code = main()
print(json.dumps({
    "code": code, **seen, "gc_enabled_after": gc.isenabled(),
    "blas": os.environ.get("OPENBLAS_NUM_THREADS"),
    "imported": sorted(m for m in ("cv2", "transitions", "requests", "robokit.sweep.engine", "robokit.fsm",
                                   "numpy.random")
                       if m in sys.modules),
}))
"""


def run_child(tmp_path: Path, env: dict[str, str], *args: str) -> dict[str, object]:
    (tmp_path / "trivial.toml").write_text(TRIVIAL)
    proc = subprocess.run([sys.executable, "-c", CHILD, *args], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    out: dict[str, object] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def test_the_command_pauses_the_collector_during_start_up_only(tmp_path: Path) -> None:
    out = run_child(tmp_path, dict(os.environ), "watch")
    assert out["code"] == 0
    assert out["gc_enabled_at_run"] is True and out["gc_enabled_after"] is True
    assert isinstance(out["frozen_at_run"], int) and out["frozen_at_run"] > 10_000  # start-up's objects
    results = list((tmp_path / "results").glob("*/result.json"))
    assert len(results) == 1 and json.loads(results[0].read_text())["outcome"] == "succeeded"


def test_a_trivial_run_uses_one_blas_thread_and_imports_only_what_it_needs(tmp_path: Path) -> None:
    out = run_child(tmp_path, {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"})
    assert out["code"] == 0 and out["gc_enabled_after"] is True
    assert out["blas"] == "1"
    assert out["imported"] == []  # no camera, no state machine: no OpenCV, transitions, requests, sweep engine;
    # nothing random: no numpy.random (the run's generator is made on first use)


def test_the_users_openblas_setting_is_kept(tmp_path: Path) -> None:
    out = run_child(tmp_path, {**os.environ, "OPENBLAS_NUM_THREADS": "2"})
    assert out["code"] == 0 and out["blas"] == "2"


def test_calling_main_from_code_leaves_the_collector_and_environment_alone(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    (tmp_path / "trivial.toml").write_text(TRIVIAL)
    frozen = gc.get_freeze_count()
    assert main(["run", "trivial.toml", "--quiet"]) == 0
    assert gc.isenabled() and gc.get_freeze_count() == frozen
    assert "OPENBLAS_NUM_THREADS" not in os.environ


# pydantic (~75 ms of import) is loaded only for plugin types whose schema is a pydantic model: the core sections
# and the local reporter are validated by robokit.config.sections.
PYDANTIC_PROBE = """
import json, sys
from robokit.cli import main
code = main(sys.argv[1:])
loader = sys.modules.get("pydantic.plugin._loader")
print(json.dumps({"code": code, "pydantic": "pydantic" in sys.modules,
                  "plugin_cache": None if loader is None else repr(getattr(loader, "_plugins", "?"))}))
"""
LIDAR = """[world]
max_time = 0.05

[robots.robot]
urdf = "robots/diffbot.urdf"
position = [0, 0, 0.06]

[sensors.scan]
type = "lidar"
rate_hz = 10
rays = {rays}
"""


def probe(tmp_path: Path, *argv: str) -> tuple[dict[str, object], str]:
    proc = subprocess.run([sys.executable, "-c", PYDANTIC_PROBE, *argv], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert "Traceback" not in proc.stderr, proc.stderr
    out: dict[str, object] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out, proc.stderr


def test_a_trivial_run_imports_no_pydantic(tmp_path: Path) -> None:
    (tmp_path / "trivial.toml").write_text(TRIVIAL)
    out, _ = probe(tmp_path, "run", "trivial.toml", "--quiet")
    assert out == {"code": 0, "pydantic": False, "plugin_cache": None}
    results = list((tmp_path / "results").glob("*/result.json"))  # the local reporter ran, with its light schema
    assert len(results) == 1 and json.loads(results[0].read_text())["outcome"] == "succeeded"


def test_a_bad_core_config_is_one_line_without_pydantic(tmp_path: Path) -> None:
    (tmp_path / "bad.toml").write_text(TRIVIAL.replace('shape = "box"', 'shape = "box"\nmass = true'))
    out, err = probe(tmp_path, "run", "bad.toml", "--quiet")
    assert out["code"] == 2 and out["pydantic"] is False
    assert err == "robokit: error: bad.toml: bodies.box.mass: input should be a valid number, got True\n"
    assert not (tmp_path / "results").exists()


@pytest.mark.slow
def test_a_plugin_with_a_pydantic_schema_imports_pydantic_and_is_validated_by_it(tmp_path: Path) -> None:
    import importlib.metadata as md

    (tmp_path / "lidar.toml").write_text(LIDAR.format(rays=36))
    out, _ = probe(tmp_path, "run", "lidar.toml", "--quiet")
    assert out["code"] == 0 and out["pydantic"] is True
    # pydantic's own scan for its plugins was answered from robokit's entry-point scan (when there are none)
    assert (out["plugin_cache"] == "{}") == (not md.entry_points(group="pydantic"))
    (tmp_path / "lidar.toml").write_text(LIDAR.format(rays=0))
    out, err = probe(tmp_path, "run", "lidar.toml", "--quiet")
    assert out["code"] == 2 and out["pydantic"] is True
    assert err == "robokit: error: lidar.toml: sensors.scan.rays: input should be greater than or equal to 1, got 0\n"
