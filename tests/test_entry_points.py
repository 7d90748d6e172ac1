"""Plugin discovery asks ``importlib.metadata`` and remembers its answer (:mod:`robokit.plugin_api.entry_points`):
the remembered answer is importlib's, and anything installed, removed or reinstalled is seen on the next run."""

from __future__ import annotations

import importlib.metadata as md
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from plugin_dists import FAULTY_SENSORS, make_dist

from robokit.plugin_api import entry_points as ep_cache
from robokit.plugin_api.plugins import load_plugins

GROUPS = ("robokit", "robokit.types", "console_scripts", "pytest11")


@pytest.fixture(autouse=True)
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("ROBOKIT_CACHE_DIR", str(folder))
    return folder


def by_importlib(groups: tuple[str, ...] = GROUPS) -> list[tuple[str, ...]]:
    every = md.entry_points()
    return [(e.group, e.name, e.value, e.dist.metadata["Name"], e.dist.metadata["Version"])  # type: ignore[union-attr]
            for g in groups for e in every.select(group=g)]


def by_robokit(groups: tuple[str, ...] = GROUPS) -> list[tuple[str, ...]]:
    return [(e.group, e.name, e.value, e.distribution, e.version) for e in ep_cache.entry_points(groups)]


def cache_files(cache: Path) -> list[Path]:
    return sorted(cache.glob("entry-points-*.json")) if cache.exists() else []


def test_the_answer_is_importlibs_asked_then_remembered(cache: Path, tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    first = by_robokit()
    assert first == by_importlib()
    assert ("robokit", "local_report", "robokit_plugins.local_report", "robokit") in [m[:4] for m in first]
    assert len(cache_files(cache)) == 1
    stamp = cache_files(cache)[0].stat().st_mtime_ns
    assert by_robokit() == first  # from the file: not rewritten
    # a folder without distributions first on sys.path (a script's folder, `python -m` in another folder): the same
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "script.py").write_text("")
    monkeypatch.syspath_prepend(str(tmp_path / "elsewhere"))
    assert by_robokit() == first
    assert len(cache_files(cache)) == 1 and cache_files(cache)[0].stat().st_mtime_ns == stamp


def test_an_installed_removed_or_reinstalled_distribution_is_seen(tmp_path: Path, cache: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    site = tmp_path / "site"
    site.mkdir()
    monkeypatch.syspath_prepend(str(site))
    assert not [m for m in by_robokit(("robokit",)) if m[3] == "robokit-extra"]
    module = make_dist(site, "robokit-extra", "1.0", FAULTY_SENSORS)
    assert [m for m in by_robokit(("robokit",)) if m[3] == "robokit-extra"] == [
        ("robokit", "main", module, "robokit-extra", "1.0")]
    # reinstalled in place: the same folder, entry_points.txt rewritten (a new time and size)
    points = site / "robokit_extra-1.0.dist-info" / "entry_points.txt"
    points.write_text(f"[robokit]\nrenamed = {module}\n")
    os.utime(points, ns=(points.stat().st_atime_ns, points.stat().st_mtime_ns + 10**9))
    assert [m[1] for m in by_robokit(("robokit",)) if m[3] == "robokit-extra"] == ["renamed"]
    # removed
    points.unlink()
    assert not [m for m in by_robokit(("robokit",)) if m[3] == "robokit-extra"]
    assert by_robokit() == by_importlib()


def test_an_egg_info_distribution_installed_later_is_seen(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The legacy layout (``NAME.egg-info``, ``PKG-INFO``; any case of the suffix, as importlib.metadata reads it)
    counts as a distribution in the remembered answer's key too."""
    site = tmp_path / "site"
    make_dist(site, "robokit-first", "1.0", FAULTY_SENSORS)  # the folder already holds a distribution
    monkeypatch.syspath_prepend(str(site))
    assert not [m for m in by_robokit(("robokit",)) if m[3] == "legacy-plugin"]
    (site / "legacy_plugin_mod.py").write_text(FAULTY_SENSORS)
    info = site / "legacy_plugin.EGG-INFO"
    info.mkdir()
    (info / "PKG-INFO").write_text("Metadata-Version: 1.1\nName: legacy-plugin\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text("[robokit]\nlegacy = legacy_plugin_mod\n")
    assert [m for m in by_robokit(("robokit",)) if m[3] == "legacy-plugin"] == [
        ("robokit", "legacy", "legacy_plugin_mod", "legacy-plugin", "0.3")]
    assert by_robokit() == by_importlib()


def test_the_first_distribution_of_a_name_on_sys_path_wins(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first = make_dist(tmp_path / "a", "robokit-extra", "1.0", FAULTY_SENSORS)
    make_dist(tmp_path / "b", "robokit_extra", "2.0", FAULTY_SENSORS)  # the same name, normalised: shadowed
    monkeypatch.syspath_prepend(str(tmp_path / "b"))
    monkeypatch.syspath_prepend(str(tmp_path / "a"))
    extra = [m for m in by_robokit(("robokit",)) if m[3] in ("robokit-extra", "robokit_extra")]
    assert extra == [("robokit", "main", first, "robokit-extra", "1.0")]
    assert by_robokit() == by_importlib()


def test_entry_point_load_with_attributes_extras_and_comments(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "probe_mod.py").write_text("class Outer:\n    class Inner:\n        pass\n")
    info = tmp_path / "probe-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: probe\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "# a comment\n[probe.group]\nwhole = probe_mod\nnested = probe_mod:Outer.Inner [extra]\n\n[other]\nx = y\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    for _ in range(2):  # asked, then remembered: the same objects load
        found = {e.name: e for e in ep_cache.entry_points(("probe.group",))}
        assert sorted(found) == ["nested", "whole"]
        assert found["whole"].load().__name__ == "probe_mod"
        assert found["nested"].load().__qualname__ == "Outer.Inner"
        assert (found["whole"].distribution, found["whole"].version) == ("probe", "0.1")


@pytest.mark.slow
def test_a_zip_on_sys_path(tmp_path: Path) -> None:
    archive = tmp_path / "zipped.zip"
    with zipfile.ZipFile(archive, "w") as zf:
        zf.writestr("zipped_plugin.py", FAULTY_SENSORS)
        zf.writestr("zipped_plugin-1.0.dist-info/METADATA",
                    "Metadata-Version: 2.1\nName: zipped-plugin\nVersion: 1.0\n")
        zf.writestr("zipped_plugin-1.0.dist-info/entry_points.txt", "[robokit]\nzipped = zipped_plugin\n")
    code = ("import sys; sys.path.insert(0, sys.argv[1])\nfrom robokit.plugin_api.plugins import load_plugins\n"
            "t = load_plugins().get('sensor', 'flaky_read')\nprint(t.origin)\n")
    for _ in range(2):
        proc = subprocess.run([sys.executable, "-c", code, str(archive)], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.splitlines()[0] == "zipped-plugin 1.0"


def test_a_remembered_answer_imports_no_importlib_metadata(cache: Path) -> None:
    code = ("import sys\nfrom robokit.plugin_api.plugins import load_plugins\n"
            "p = load_plugins()\np.get('reporter', 'local')\n"
            "print('importlib.metadata' in sys.modules, 'email' in sys.modules)")
    answers = []
    for _ in range(2):
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        answers.append(proc.stdout.strip().splitlines()[-1])
    assert answers == ["True True", "False False"]  # the first run asked importlib.metadata; the second did not
    assert load_plugins().get("reporter", "local").origin.startswith("robokit ")


def test_a_cache_that_cannot_be_written_or_read_is_ignored(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                           cache: Path) -> None:
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")
    monkeypatch.setenv("ROBOKIT_CACHE_DIR", str(blocked / "cache"))
    assert by_robokit() == by_importlib()
    monkeypatch.setenv("ROBOKIT_CACHE_DIR", str(cache))
    by_robokit()
    for junk in ("{not json", '{"key": 1}', "[]", '{"key": null, "entry_points": 3}'):
        cache_files(cache)[0].write_text(junk)
        assert by_robokit() == by_importlib()


def test_an_import_hook_with_distributions_of_its_own_is_asked_every_time(monkeypatch: pytest.MonkeyPatch,
                                                                          cache: Path) -> None:
    class Finder:
        @staticmethod
        def find_spec(*_args: object) -> None:
            return None

        @staticmethod
        def find_distributions(*_args: object, **_kwargs: object) -> list[object]:
            return []

    monkeypatch.setattr(sys, "meta_path", [*sys.meta_path, Finder])
    assert by_robokit() == by_importlib()
    assert cache_files(cache) == []
