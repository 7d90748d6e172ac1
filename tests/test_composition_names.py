"""Type names that cannot clash silently: two installed distributions registering one type name.

The distributions are fakes on disk (``tests/plugin_dists.py``: a ``*.dist-info`` folder and a module), exactly
what pip leaves in site-packages. Nothing depends on which one loads first: the bare name is refused naming both,
``distribution:type`` picks each, and a config error about the section names the distribution it went to.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import pytest
from plugin_dists import make_dist

from robokit.cli import main
from robokit.plugin_api.plugins import PluginLoadWarning, load_plugins
from robokit.testing import validate_error

LABELLED = '''
from robokit import hookimpl
from robokit.components import Sensor
from robokit.config import Schema


class LabelConfig(Schema):
    """``scale``: multiplies the reading."""

    scale: float = 1.0


class Label(Sensor):
    """Reads its distribution's label times ``scale`` (tells the two apart)."""

    reading_type = float

    def read(self):
        return {label} * self.config.scale


@hookimpl
def robokit_register_sensors(register):
    register("rangefinder", Label, LabelConfig)
'''


@pytest.fixture
def two_dists(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """alpha-sensors and beta-sensors both register sensor type ``rangefinder`` (reading 1.0 and 2.0)."""
    make_dist(tmp_path / "site", "alpha-sensors", "1.0", LABELLED.replace("{label}", "1.0"))
    make_dist(tmp_path / "site", "beta_sensors", "2.0", LABELLED.replace("{label}", "2.0"))
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _config(folder: Path, type_name: str, extra: str = "") -> Path:
    path = folder / f"c_{abs(hash(type_name + extra))}.toml"
    path.write_text(f'[world]\nmax_time = 0.05\n[bodies.ball]\nshape = "sphere"\nradius = 0.1\nmass = 1\n'
                    f'position = [0, 0, 1]\n[sensors.range]\ntype = "{type_name}"\n{extra}'
                    f'[behaviour]\ntype = "record"\ncomponents = ["range"]\nduration = 0.02\n')
    return path


def test_the_bare_name_is_refused_naming_both_distributions(two_dists: Path) -> None:
    plugins = load_plugins()
    assert {t.distribution for t in plugins.ambiguous["sensor"]["rangefinder"]} == {"alpha-sensors", "beta_sensors"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginLoadWarning)
        line = validate_error(_config(two_dists, "rangefinder"))
    assert line.endswith("sensors.range.type: sensor type 'rangefinder' is ambiguous: it is registered by "
                         "alpha-sensors 1.0 and beta_sensors 2.0; write 'alpha-sensors:rangefinder' or "
                         "'beta_sensors:rangefinder'"), line


@pytest.mark.parametrize("written,expected", [("alpha-sensors:rangefinder", 1.0), ("beta_sensors:rangefinder", 2.0),
                                              ("Beta-Sensors:rangefinder", 2.0)])  # as pip compares names
def test_distribution_colon_type_runs_each(two_dists: Path, written: str, expected: float,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginLoadWarning)
        assert main(["run", str(_config(two_dists, written, "scale = 3.0\n")), "--json", "--no-record"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["outcome"] == "succeeded"
    assert result["result"]["last"]["range"] == expected * 3.0  # the chosen distribution's sensor read


def test_a_section_error_names_the_distribution_providing_the_type(two_dists: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginLoadWarning)
        line = validate_error(_config(two_dists, "beta_sensors:rangefinder", "order = 2\n"))
    assert "sensors.range.order: unknown key 'order'" in line
    assert line.endswith("(sensor type 'rangefinder' from beta_sensors 2.0)"), line


def test_a_distribution_that_does_not_provide_the_type_is_named(two_dists: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginLoadWarning)
        line = validate_error(_config(two_dists, "gamma:rangefinder"))
    assert line.endswith("no sensor type 'rangefinder' in distribution 'gamma'; 'rangefinder' comes from: "
                         "alpha-sensors:rangefinder, beta_sensors:rangefinder"), line


def test_load_order_decides_nothing(two_dists: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same answer with the two distributions found in the opposite order on sys.path."""
    site2 = two_dists / "site2"
    site2.mkdir()
    for item in sorted((two_dists / "site").iterdir()):
        if item.name.startswith("beta"):
            item.rename(site2 / item.name)
    monkeypatch.syspath_prepend(str(site2))  # beta is now found first
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginLoadWarning)
        plugins = load_plugins()
        line = validate_error(_config(two_dists, "rangefinder"))
    assert [t.distribution for t in plugins.ambiguous["sensor"]["rangefinder"]] == ["alpha-sensors", "beta_sensors"]
    assert "registered by alpha-sensors 1.0 and beta_sensors 2.0" in line


def test_a_builtin_name_stays_the_builtin_and_the_other_is_reachable_qualified(tmp_path: Path,
                                                                               monkeypatch: Any) -> None:
    make_dist(tmp_path, "aaa-copycat", "0.1", LABELLED.replace("{label}", "7.0").replace('"rangefinder"',
                                                                                           '"body_pose"'))
    monkeypatch.syspath_prepend(str(tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter("error", PluginLoadWarning)  # listed by `robokit plugins`, not warned on every command
        plugins = load_plugins()
    assert [t.distribution for t in plugins.shadowed["sensor"]["body_pose"]] == ["aaa-copycat"]
    assert plugins.get("sensor", "body_pose").distribution == "robokit"
    assert plugins.get("sensor", "aaa-copycat:body_pose").distribution == "aaa-copycat"
    assert plugins.get("sensor", "robokit:body_pose") is plugins.get("sensor", "body_pose")


@pytest.mark.parametrize("claimed", ["robokit:body_pose", "other-dist:rangefinder"])
def test_a_package_registers_names_under_its_own_distribution_only(tmp_path: Path, monkeypatch: Any,
                                                                   capsys: pytest.CaptureFixture[str],
                                                                   claimed: str) -> None:
    make_dist(tmp_path, "squatter", "0.1", LABELLED.replace("{label}", "9.0").replace('"rangefinder"',
                                                                                      f'"{claimed}"'))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.warns(PluginLoadWarning, match=f"sensor type '{claimed}' not registered: a type name has no "
                                               "distribution part"):
        plugins = load_plugins()
    assert all(t.distribution != "squatter" for t in plugins.all_types())
    assert plugins.get("sensor", "robokit:body_pose").distribution == "robokit"
    assert main(["plugins"]) == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if "squatter" in line]
    assert len(listed) == 1 and listed[0].startswith("not loaded: squatter (squatter:main): "), listed
