"""Loading third-party plugin distributions: broken ones are isolated, bad hooks rejected, clashes named.

Each test puts fake distributions (``tests/plugin_dists.py``) on ``sys.path``; ``load_plugins()`` builds a fresh
plugin manager every time, so nothing leaks between tests.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest
from plugin_dists import BAD_SIGNATURE, BROKEN_IMPORT, GOOD_SENSOR, HALF_REGISTERING, UNKNOWN_HOOK, make_dist

from robokit.cli import main
from robokit.errors import UserError
from robokit.plugin_api.plugins import PluginLoadWarning, load_plugins


def toml_config(path: Path, sensor_type: str) -> Path:
    path.write_text(
        '[world]\nmax_time = 0.05\n[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'
        f'[sensors.s]\ntype = "{sensor_type}"\n'
    )
    return path


@pytest.fixture
def broken_and_good(tmp_path, monkeypatch):
    """A distribution whose plugin module fails to import, and a good one."""
    make_dist(tmp_path, "broken-dist", "0.3.0", BROKEN_IMPORT)
    make_dist(tmp_path, "good-dist", "2.3.1", GOOD_SENSOR, type_name="good_probe")
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def test_import_failure_warns_naming_the_distribution_and_the_others_still_load(broken_and_good):
    with pytest.warns(PluginLoadWarning, match=r"broken-dist \(entry point 'main'\) not loaded: import failed: "
                                               r"ModuleNotFoundError"):
        plugins = load_plugins()
    assert "good_probe" in plugins.types["sensor"]
    assert plugins.types["sensor"]["good_probe"].origin == "good-dist 2.3.1"
    assert "body_pose" in plugins.types["sensor"]  # robokit's own entry points load too
    assert "drop_test" in plugins.types["behaviour"]
    assert list(plugins.broken) == ["broken-dist (entry point 'main')"]


def test_only_a_config_using_the_broken_distribution_fails_and_it_says_why(broken_and_good, capsys):
    good = toml_config(broken_and_good / "good.toml", "good_probe")
    assert main(["validate", str(good)]) == 0
    out = capsys.readouterr()
    assert "ok" in out.out
    warned = "robokit: warning: robokit plugin broken-dist (entry point 'main') not loaded: import failed"
    assert out.err.startswith(warned) and out.err.count("\n") == 1  # one warning line, the run goes on

    bad = toml_config(broken_and_good / "bad.toml", "ghost")
    assert main(["validate", str(bad)]) == 2
    warning, err = capsys.readouterr().err.strip().splitlines()  # the warning, then the one error line
    assert warning.startswith(warned) and "Traceback" not in err
    assert f"{bad}: sensors.s.type: unknown sensor type 'ghost'" in err
    assert "broken-dist (entry point 'main') failed to load: import failed: ModuleNotFoundError" in err
    assert "robokit_this_dependency_is_not_installed" in err


def test_hookimpl_with_a_signature_not_matching_its_spec_is_rejected_at_load(tmp_path, monkeypatch):
    make_dist(tmp_path, "odd-dist", "1.0", BAD_SIGNATURE)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.warns(PluginLoadWarning) as caught:
        plugins = load_plugins()
    message = str(caught[0].message)
    assert message.startswith("robokit plugin odd-dist (entry point 'main') not loaded: ")
    assert "robokit_register_sensors" in message
    assert "robokit_register_sensors(register, colour)" in message  # the offending definition
    assert "{'colour'} are declared in the hookimpl but can not be found in the hookspec" in message
    assert not any(t.distribution == "odd-dist" for t in plugins.all_types())
    assert "body_pose" in plugins.types["sensor"]


def test_hookimpl_of_an_unknown_hook_is_rejected_at_load(tmp_path, monkeypatch):
    make_dist(tmp_path, "typo-dist", "1.0", UNKNOWN_HOOK)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.warns(PluginLoadWarning, match=r"typo-dist .* implements unknown hook\(s\) robokit_register_sensor$"):
        plugins = load_plugins()
    assert "body_pose" in plugins.types["sensor"]


def test_a_registration_hook_that_raises_leaves_none_of_its_types(tmp_path, monkeypatch):
    make_dist(tmp_path, "half-dist", "1.0", HALF_REGISTERING)
    monkeypatch.syspath_prepend(str(tmp_path))
    expected = r"half-dist .* robokit_register_sensors raised KeyError\('second_half'\)"
    with pytest.warns(PluginLoadWarning, match=expected):
        plugins = load_plugins()
    assert "first_half" not in plugins.types["sensor"]
    assert "body_pose" in plugins.types["sensor"]


def test_two_types_with_one_name_make_the_bare_name_ambiguous_and_both_are_listed(tmp_path, monkeypatch, capsys):
    # load order decides nothing (tests/test_composition_names.py has the config side: dist:type runs each)
    make_dist(tmp_path, "alpha-sensors", "1.0", GOOD_SENSOR, type_name="rangefinder")
    make_dist(tmp_path, "beta-sensors", "2.0", GOOD_SENSOR, type_name="rangefinder")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugins = load_plugins()
    with pytest.raises(UserError, match="sensor type 'rangefinder' is ambiguous: it is registered by alpha-sensors "
                                        "1.0 and beta-sensors 2.0; write 'alpha-sensors:rangefinder' or "
                                        "'beta-sensors:rangefinder'"):
        plugins.get("sensor", "rangefinder")
    assert plugins.get("sensor", "beta-sensors:rangefinder").origin == "beta-sensors 2.0"

    assert main(["plugins"]) == 0  # every command still works
    out, err = capsys.readouterr()
    assert [line.split()[1] for line in out.splitlines() if "rangefinder" in line and
            not line.startswith("clash: ")] == ["alpha-sensors:rangefinder", "beta-sensors:rangefinder"]
    assert [line for line in out.splitlines() if line.startswith("clash: ")] == [  # once, with both owners
        "clash: sensor type 'rangefinder': alpha-sensors 1.0 (as 'alpha-sensors:rangefinder') and beta-sensors 2.0 "
        "(as 'beta-sensors:rangefinder')"]
    assert "rangefinder" not in err


def test_a_type_clashing_with_a_builtin_is_listed_qualified_and_the_builtin_keeps_its_name(tmp_path, monkeypatch,
                                                                                            capsys):
    # "aaa-copycat" sorts before "robokit": it is loaded first, yet the built-in keeps the name
    make_dist(tmp_path / "dists", "aaa-copycat", "0.1", GOOD_SENSOR, type_name="body_pose")
    monkeypatch.syspath_prepend(str(tmp_path / "dists"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", PluginLoadWarning)  # a clash warns on no command
        plugins = load_plugins()
    assert plugins.get("sensor", "body_pose").origin.startswith("robokit ")

    assert main(["plugins"]) == 0
    out, err = capsys.readouterr()
    assert [line.split()[1:3] for line in out.splitlines()
            if line.startswith("sensor ") and line.split()[1].endswith("body_pose")] == [
        ["aaa-copycat:body_pose", "aaa-copycat"], ["body_pose", "robokit"]]
    assert [line for line in out.splitlines() if line.startswith("clash: ")] == [
        "clash: sensor type 'body_pose': robokit 0.1.0 (the bare name) and aaa-copycat 0.1 (as "
        "'aaa-copycat:body_pose')"]
    assert "aaa-copycat" not in err
    config = tmp_path / "c.toml"
    config.write_text('[world]\nmax_time = 0.05\n[bodies.ball]\nshape = "sphere"\nradius = 0.1\nmass = 1\n'
                      'position = [0, 0, 1]\n[sensors.s]\ntype = "body_pose"\n')
    assert main(["validate", str(config)]) == 0
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(config), "--quiet"]) == 0
    assert main(["graph", "pick_place"]) == 0


def test_plugins_command_shows_kind_type_distribution_version_description(broken_and_good, capsys):
    assert main(["plugins"]) == 0
    lines = capsys.readouterr().out.splitlines()
    probe = next(line for line in lines if " good_probe " in line)
    assert probe.split()[:4] == ["sensor", "good_probe", "good-dist", "2.3.1"]
    assert probe.endswith("Reads the sim time in seconds (a third-party sensor that works).")
    pose = next(line for line in lines if " body_pose " in line)
    assert pose.split()[:4] == ["sensor", "body_pose", "robokit", "0.1.0"]
    assert pose.endswith("Ground-truth pose and velocity of named bodies (a dict of name -> BodyState).")
    kinds = {line.split()[0] for line in lines if not line.startswith("not loaded")}
    assert kinds == {"sensor", "actuator", "behaviour", "reporter", "task"}
    assert lines[-1].startswith("not loaded: broken-dist (entry point 'main'): import failed: ModuleNotFoundError")

    assert main(["plugins", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    row = next(r for r in data["types"] if r["type"] == "good_probe")
    assert row == {"kind": "sensor", "type": "good_probe", "distribution": "good-dist", "version": "2.3.1",
                   "description": "Reads the sim time in seconds (a third-party sensor that works)."}
    assert list(data["broken"]) == ["broken-dist (entry point 'main')"]


def test_the_type_index_names_the_module_of_every_builtin_type():
    """pyproject's "robokit.types" entry points say which module registers each built-in type (lazy loading)."""
    import importlib.metadata as md

    modules = {ep.name: ep.value for ep in md.entry_points(group="robokit")}
    index = {ep.name: ep.value for ep in md.entry_points(group="robokit.types")}
    registered = {f"{t.kind}.{t.name}": modules[t.plugin.split(":", 1)[1]]
                  for t in load_plugins(lazy=False).all_types() if t.distribution == "robokit"}
    missing = sorted(f'"{key}" = "{module}"' for key, module in registered.items() if index.get(key) != module)
    assert not missing, 'add to [project.entry-points."robokit.types"] in pyproject.toml: ' + "; ".join(missing)
    assert set(index) == set(registered)


def test_a_config_imports_only_the_plugin_modules_it_uses():
    """Loading the patrol config imports the lidar, drive and patrol modules, not the camera's (nor OpenCV)."""
    import subprocess
    import sys

    code = ("import sys; from robokit.plugin_api.plugins import load_plugins; from robokit.config import load_config; "
            "p = load_plugins(); load_config(sys.argv[1], p); "
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('robokit_') or m == 'cv2')))")
    config = Path(__file__).resolve().parent.parent / "configs" / "patrol_robot.toml"
    out = subprocess.run([sys.executable, "-c", code, str(config)], capture_output=True, text=True, check=True)
    loaded = set(out.stdout.split())
    assert {"robokit_plugins.lidar", "robokit_plugins.diff_drive", "robokit_behaviours.patrol_collect"} <= loaded
    assert "cv2" not in loaded and "robokit_plugins.camera" not in loaded and "robokit_behaviours.sort" not in loaded


def test_lazy_and_eager_loading_find_the_same_types():
    lazy, eager = load_plugins(), load_plugins(lazy=False)
    assert lazy.get("sensor", "lidar").cls is eager.get("sensor", "lidar").cls
    assert [(t.kind, t.name, t.origin) for t in lazy.all_types()] == [(t.kind, t.name, t.origin)
                                                                      for t in eager.all_types()]
