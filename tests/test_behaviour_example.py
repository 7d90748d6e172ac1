"""The behaviour guide's example package, the way a third party ships it: a wheel built with ``pip wheel --no-deps``,
installed into a fresh virtual environment, seen by ``robokit plugins``, drawn by ``robokit graph``, run from its
config, and passing its own tests (scripted readings, config timeouts, ``check_behaviour``) against the installed
copy.

The venv is made like ``tests/test_plugins_example.py`` makes its own: ``--without-pip`` off the running
interpreter, with a ``.pth`` line that makes the running environment's site-packages importable after the venv's
own (robokit's dependencies come from there, nothing big is downloaded); robokit (a copy of this checkout) and the
example are built as wheels (pip fetches only setuptools for the isolated builds) and installed into it.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import sysconfig
from pathlib import Path

import pytest
from test_plugins_example import IGNORE, _pip, _run

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "robokit-example-behaviour"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("behaviour-venv")
    assert _run([sys.executable, "-m", "venv", "--without-pip", tmp / "venv"], tmp).returncode == 0
    python = tmp / "venv" / ("Scripts" if os.name == "nt" else "bin") / ("python.exe" if os.name == "nt" else "python")
    site = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp).stdout.strip())
    paths = dict.fromkeys(sysconfig.get_paths()[key] for key in ("purelib", "platlib"))
    (site / "00_robokit_deps.pth").write_text("".join(f"{path}\n" for path in paths))
    src = tmp / "src"
    for part in ("robokit", "plugins", "behaviours", "configs/gym"):  # configs/gym: the package robokit_configs.gym
        shutil.copytree(ROOT / part, src / "robokit" / part, ignore=IGNORE)
    for part in ("pyproject.toml", "README.md", "LICENSE"):
        if (ROOT / part).exists():
            shutil.copy2(ROOT / part, src / "robokit" / part)
    shutil.copytree(EXAMPLE, src / "example", ignore=IGNORE)
    wheels = tmp / "wheels"  # build isolation: pip fetches the small build backend (setuptools) the projects ask for
    built = _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--disable-pip-version-check",
                  "-w", wheels, src / "robokit", src / "example"], tmp)
    assert built.returncode == 0, built.stdout + built.stderr
    assert sorted(p.name.split("-")[0] for p in wheels.glob("*.whl")) == ["robokit", "robokit_example_wander"]
    _pip(python, "--no-deps", *sorted(wheels.glob("*.whl")), cwd=tmp)
    return {"python": python, "example": src / "example", "tmp": tmp, "site": site}


def test_the_wheel_is_installed_and_robokit_lists_the_behaviour(venv: dict[str, Path]) -> None:
    code = "import robokit_example_wander as m; print(m.__file__)"
    proc = _run([venv["python"], "-c", code], venv["tmp"])
    assert Path(proc.stdout.strip()).is_relative_to(venv["site"]), proc.stdout + proc.stderr
    proc = _run([venv["python"], "-m", "robokit.cli", "plugins", "--json"], venv["tmp"])
    types = {(t["kind"], t["type"]): t for t in json.loads(proc.stdout)["types"]}
    wander = types[("behaviour", "wander")]
    assert (wander["distribution"], wander["version"]) == ("robokit-example-wander", "0.1.0")
    assert wander["description"] == ("Drives ahead, turns away from obstacles the lidar sees, and succeeds after a "
                                     "set distance.")


def test_the_installed_behaviour_runs_its_demo_and_draws_its_graph(venv: dict[str, Path]) -> None:
    config = venv["example"] / "configs" / "wander_demo.toml"
    proc = _run([venv["python"], "-m", "robokit.cli", "run", config, "--json"], venv["tmp"])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    result = json.loads(proc.stdout)
    assert result["outcome"] == "succeeded" and result["result"]["distance"] >= 4.0
    assert result["result"]["visited"][:3] == ["DRIVE", "TURN", "DRIVE"]
    proc = _run([venv["python"], "-m", "robokit.cli", "graph", "wander"], venv["tmp"])
    assert "TURN --> DRIVE: clear" in proc.stdout


def test_the_example_package_own_tests_pass_against_the_installed_copy(venv: dict[str, Path]) -> None:
    proc = _run([venv["python"], "-m", "pytest", "-q", "-p", "no:cacheprovider", venv["example"] / "tests"],
                venv["example"], timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "8 passed" in proc.stdout
