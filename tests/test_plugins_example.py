"""End to end, the way a third party works: install robokit and the example plugin package with pip into a fresh
virtual environment, see the new type in ``robokit plugins``, run its config with ``--trace`` and find its
readings there, and run the package's own tests (which include ``check_sensor``) against the installed copy.

The fresh environment is ``python -m venv --without-pip`` off the running interpreter. Instead of downloading
pybullet, numpy, etc. again, a ``.pth`` line makes the running environment's site-packages importable *after* the
venv's own (the effect of ``--system-site-packages``, which a venv made from inside a venv would not give). robokit
itself (a copy of this checkout) and ``examples/robokit-example-plugin`` are built and installed into the venv as
real, non-editable wheels with ``pip --python VENV``; the only download is a setuptools that can build wheels
(from PyPI) when the running environment's cannot.
"""

from __future__ import annotations

import importlib.metadata as md
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "robokit-example-plugin"
IGNORE = shutil.ignore_patterns("__pycache__", "*.egg-info", "build", "dist", "results", ".pytest_cache")


def _can_build_wheels() -> bool:
    if importlib.util.find_spec("wheel") is not None:
        return True
    try:
        version = tuple(int(p) for p in md.version("setuptools").split(".")[:2])
    except (md.PackageNotFoundError, ValueError):
        return False
    return version >= (70, 1)  # setuptools >= 70.1 builds wheels without the wheel package


def _run(args: list[str | Path], cwd: Path, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    return subprocess.run([str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


def _pip(venv_python: Path, *args: str | Path, cwd: Path) -> None:
    proc = _run([sys.executable, "-m", "pip", "--python", venv_python, "install", "-q",
                 "--disable-pip-version-check", *args], cwd)
    assert proc.returncode == 0, proc.stdout + proc.stderr


pytestmark = pytest.mark.slow  # builds and installs two packages into a venv: the slow tier


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A fresh venv with robokit and robokit-example-imu installed from copies of their sources."""
    tmp = tmp_path_factory.mktemp("example-venv")
    proc = _run([sys.executable, "-m", "venv", "--without-pip", tmp / "venv"], tmp)
    assert proc.returncode == 0, proc.stderr
    bindir = "Scripts" if os.name == "nt" else "bin"
    python = tmp / "venv" / bindir / ("python.exe" if os.name == "nt" else "python")
    site = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp)
                .stdout.strip())
    paths = dict.fromkeys([*(sysconfig.get_paths()[key] for key in ("purelib", "platlib")),
                           *(p for p in sys.path if p.endswith("site-packages"))])  # a venv over a venv too
    (site / "00_robokit_deps.pth").write_text("".join(f"{path}\n" for path in paths))
    src = tmp / "src"
    for part in ("robokit", "plugins", "behaviours", "configs/gym"):  # configs/gym: the package robokit_configs.gym
        shutil.copytree(ROOT / part, src / "robokit" / part, ignore=IGNORE)
    for part in ("pyproject.toml", "README.md", "LICENSE"):
        if (ROOT / part).exists():
            shutil.copy2(ROOT / part, src / "robokit" / part)
    shutil.copytree(EXAMPLE, src / "example", ignore=IGNORE)
    if not _can_build_wheels():
        _pip(python, "setuptools>=70.1", cwd=tmp)  # from PyPI, into the venv only
    _pip(python, "--no-deps", "--no-build-isolation", src / "robokit", src / "example", cwd=tmp)
    return {"python": python, "bin": python.parent, "example": src / "example", "tmp": tmp, "site": site}


def test_both_packages_are_installed_into_the_venv_not_used_from_the_checkout(venv):
    code = "import robokit, robokit_example_imu; print(robokit.__file__); print(robokit_example_imu.__file__)"
    proc = _run([venv["python"], "-c", code], venv["tmp"])
    assert proc.returncode == 0, proc.stderr
    for line in proc.stdout.splitlines():
        assert Path(line).is_relative_to(venv["site"]), line


def test_robokit_plugins_lists_the_new_type(venv):
    proc = _run([venv["bin"] / "robokit", "plugins"], venv["tmp"])
    assert proc.returncode == 0, proc.stderr
    imu = next(line for line in proc.stdout.splitlines() if line.split()[:2] == ["sensor", "imu"])
    assert imu.split()[2:4] == ["robokit-example-imu", "0.1.0"]
    assert imu.endswith("IMU on a named link: specific force (m/s²) and angular velocity (rad/s) in the link frame.")
    broken = [line for line in proc.stdout.splitlines() if line.startswith("not loaded")]
    assert not [line for line in broken if "robokit-example-imu" in line], broken


def test_the_example_config_runs_and_its_readings_are_in_the_trace(venv):
    trace = venv["tmp"] / "imu_trace.jsonl"
    config = venv["example"] / "configs" / "imu_demo.toml"
    proc = _run([venv["bin"] / "robokit", "run", config, "--trace", trace, "--json"], venv["tmp"])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    result = json.loads(proc.stdout)
    assert result["outcome"] == "succeeded" and result["result"]["recorded"] == {"imu": 121}
    records = [json.loads(line) for line in trace.read_text().splitlines()]
    samples = [r for r in records if r["kind"] == "reading" and r["component"] == "imu"]
    assert len(samples) == 121 and samples[1]["tick"] == 4  # 60 Hz of 240 Hz physics, for 2 s
    first = samples[1]["value"]
    assert set(first) == {"linear_acceleration", "angular_velocity", "frame", "time", "orientation"}  # msgs.Imu
    assert first["frame"] and first["orientation"] is None  # the frame is named in every reading
    assert len(first["linear_acceleration"]) == 3 and len(first["angular_velocity"]) == 3
    falling = samples[5]["value"]["linear_acceleration"]  # t = 0.083 s: in free fall, no specific force
    resting = samples[-1]["value"]["linear_acceleration"]  # t = 2 s: settled on the ground
    assert sum(v * v for v in falling) ** 0.5 < 0.5
    assert 9.5 < sum(v * v for v in resting) ** 0.5 < 10.1
    assert list((venv["tmp"] / "results").glob("*/result.json"))  # the local reporter kept the result


def test_the_example_package_own_tests_pass_against_the_installed_copy(venv):
    proc = _run([venv["python"], "-m", "pytest", "-q", "-p", "no:cacheprovider", venv["example"] / "tests"],
                venv["example"])
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    # every test the package ships ran and passed (counted from its sources, not copied from an earlier output)
    shipped = sum(path.read_text(encoding="utf-8").count("\ndef test_")
                  for path in (venv["example"] / "tests").glob("test_*.py"))
    assert shipped >= 5 and f"{shipped} passed" in proc.stdout, proc.stdout[-500:]
