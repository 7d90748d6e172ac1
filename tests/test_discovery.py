"""robokit's own entry-point reader (:mod:`robokit.plugin_api.discovery`) finds what ``importlib.metadata`` finds,
and steps
aside where it cannot (a zip on ``sys.path``): plugin discovery then asks ``importlib.metadata``."""

from __future__ import annotations

import importlib.metadata as md
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from plugin_dists import FAULTY_SENSORS, make_dist

from robokit.plugin_api import discovery
from robokit.plugin_api.plugins import load_plugins

GROUPS = ("robokit", "robokit.types", "console_scripts", "pytest11", "pydantic")


def by_importlib(groups: tuple[str, ...] = GROUPS) -> list[tuple[str, ...]]:
    every = md.entry_points()
    return sorted((e.group, e.name, e.value, e.dist.metadata["Name"], e.dist.metadata["Version"])  # type: ignore[union-attr]
                  for g in groups for e in every.select(group=g))


def by_robokit(groups: tuple[str, ...] = GROUPS) -> list[tuple[str, ...]]:
    found = discovery.entry_points(groups)
    assert found is not None
    return sorted((e.group, e.name, e.value, e.dist.metadata.get("Name", ""), e.dist.metadata.get("Version", ""))
                  for e in found)


def test_the_same_entry_points_as_importlib_metadata_in_this_environment() -> None:
    mine = by_robokit()
    assert mine == by_importlib()
    assert ("robokit", "local_report", "robokit_plugins.local_report", "robokit") in [m[:4] for m in mine]


@pytest.mark.parametrize("stem", ["robokit-0.1.0", "Foo.Bar-1.0", "foo__bar-2", "a-._b-3", "_x_-1", "zope.interface-7",
                                  "PySocks-1.7.1", "typing_extensions-4", "plain"])
def test_distribution_names_are_normalised_as_importlib_metadata_does(stem: str) -> None:
    import re

    name = stem.partition("-")[0]
    assert discovery._normalized(stem) == re.sub(r"[-_.]+", "-", name).lower().replace("-", "_")


def test_a_distribution_on_sys_path_the_first_of_a_name_winning(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    first = make_dist(tmp_path / "a", "robokit-extra", "1.0", FAULTY_SENSORS)
    make_dist(tmp_path / "b", "robokit_extra", "2.0", FAULTY_SENSORS)  # the same name, normalised: shadowed
    monkeypatch.syspath_prepend(str(tmp_path / "b"))
    monkeypatch.syspath_prepend(str(tmp_path / "a"))
    extra = [m for m in by_robokit(("robokit",)) if m[3] == "robokit-extra" or m[3] == "robokit_extra"]
    assert extra == [("robokit", "main", first, "robokit-extra", "1.0")]
    assert by_robokit() == by_importlib()


def test_entry_point_load_and_comments(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "probe_mod.py").write_text("class Outer:\n    class Inner:\n        pass\n")
    info = tmp_path / "probe-0.1.dist-info"
    info.mkdir()
    (info / "entry_points.txt").write_text(
        "# a comment\n[probe.group]\nwhole = probe_mod\nnested = probe_mod:Outer.Inner [extra]\n\n[other]\nx = y\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    found = {e.name: e for e in discovery.entry_points(("probe.group",)) or []}
    assert sorted(found) == ["nested", "whole"]
    assert found["whole"].load().__name__ == "probe_mod"
    assert found["nested"].load().__qualname__ == "Outer.Inner"
    assert found["whole"].dist.metadata == {}  # no METADATA file: no name, no version


def test_a_zip_on_sys_path_hands_discovery_to_importlib_metadata(tmp_path: Path) -> None:
    archive = tmp_path / "zipped.zip"
    with zipfile.ZipFile(archive, "w") as zf:
        zf.writestr("zipped_plugin.py", FAULTY_SENSORS)
        zf.writestr("zipped_plugin-1.0.dist-info/METADATA",
                    "Metadata-Version: 2.1\nName: zipped-plugin\nVersion: 1.0\n")
        zf.writestr("zipped_plugin-1.0.dist-info/entry_points.txt", "[robokit]\nzipped = zipped_plugin\n")
    code = ("import sys; sys.path.insert(0, sys.argv[1])\n"
            "from robokit.plugin_api import discovery\nfrom robokit.plugin_api.plugins import load_plugins\n"
            "print(discovery.entry_points(['robokit']) is None)\n"
            "t = load_plugins().get('sensor', 'flaky_read')\nprint(t.origin)\n")
    proc = subprocess.run([sys.executable, "-c", code, str(archive)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[:2] == ["True", "zipped-plugin 1.0"]


def test_discovery_imports_no_importlib_metadata() -> None:
    code = ("import sys\nfrom robokit.plugin_api.plugins import load_plugins\n"
            "p = load_plugins()\np.get('reporter', 'local')\n"
            "print('importlib.metadata' in sys.modules, 'email' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "False False"
    assert load_plugins().get("reporter", "local").origin.startswith("robokit ")
