"""The complete sensor printed in docs/plugins.md works as printed: it conforms and measures what it says."""

from __future__ import annotations

import math
import re
import sys
import types
from pathlib import Path

import pytest

from robokit.testing import check_sensor, make_sim

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "plugins.md"


def guide_module() -> types.ModuleType:
    """The guide's "smallest complete sensor" code block, executed as a module."""
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(encoding="utf-8"), flags=re.S)
    (source,) = [b for b in blocks if b.startswith('"""my_robokit_sensors/range.py')]
    module = types.ModuleType("my_robokit_sensors_range")
    sys.modules[module.__name__] = module  # dataclasses resolve annotations through sys.modules
    exec(compile(source, str(GUIDE), "exec"), module.__dict__)  # noqa: S102 - the guide's own example
    return module


def test_the_guide_sensor_passes_the_conformance_check():
    report = check_sensor("range_finder", extra_plugins=[guide_module()])
    assert report.type_name == "range_finder" and report.computed == 12


def test_the_guide_sensor_measures_the_distance_to_the_wall():
    module = guide_module()
    scene = module.RangeFinder.example
    config = {"bodies": scene["bodies"], "sensors": {"range": {"type": "range_finder", "body": "probe"}}}
    with make_sim(config, extra_plugins=[module]) as sim:
        sim.step(1)
        reading = sim.readings["range"]
        sim.world.set_pose("probe", (0, 0, 0.2), (0, 0, 1, 0))  # turned 180 degrees: facing away from the wall
        sim.step(1)
        away = sim.readings["range"]
    assert reading.hit == "wall" and reading.distance == pytest.approx(0.95, abs=1e-3)  # wall face at x = 0.95
    assert away.hit is None and math.isinf(away.distance)


@pytest.mark.slow  # pip builds a wheel in an isolated build environment
def test_the_guide_wheel_command_builds_a_plugin_that_pins_robokit(tmp_path: Path) -> None:
    import shutil
    import subprocess

    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "plugins.md").read_text(encoding="utf-8")
    section = text[text.index("## 13. Packaging"):text.index("## 14. Checklist")]
    command = re.search(r"`(pip wheel [^`]*)`", section)
    assert command is not None
    package = tmp_path / "pkg"
    shutil.copytree(root / "examples" / "robokit-example-behaviour", package)
    assert 'dependencies = ["robokit>=0.1,<0.2"]' in (package / "pyproject.toml").read_text()  # it pins robokit
    done = subprocess.run([sys.executable, "-m", *command[1].split(), "-q", "--disable-pip-version-check"],
                          cwd=package, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert [w.name for w in (package / "dist").glob("*.whl")] == ["robokit_example_wander-0.1.0-py3-none-any.whl"]
