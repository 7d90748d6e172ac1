"""Config mistakes, generated: every one is one line naming the file, the key path and what was wrong.

docs/configs.md promises that "every error is one line naming the file and the key path", that unknown keys get a
"did you mean", that types are strict (``mass = true`` or a number written as a string is refused, never coerced),
that every number must be finite and within its range. Here a valid config file with core sections and plugin
sections (lidar, force_torque, gripper, ik_arm) has one of its keys made wrong in a generated way -- a bool or a
string for a number, ``nan`` or ``inf``, a number just past a documented bound, a misspelt key -- and
``robokit validate`` is run on the file written out. The oracle is the bounds table of docs/config-reference.md,
written out below, and the mistake itself: the line must name the file, the exact key path (with the element's
index for a vector), the rule broken (the bound as documented) and the value found.
"""

from __future__ import annotations

import difflib
import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.cli import main
from robokit.config import load_config
from robokit.errors import ConfigError
from robokit.plugin_api.plugins import load_plugins

PROPS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
CLI = settings(PROPS, max_examples=40)  # through `robokit validate` itself

BASE: dict[str, dict[str, Any]] = {
    "world": {"max_time": 1.0, "time_step": 1.0 / 240.0, "solver_iterations": 50, "seed": 0,
              "gravity": [0.0, 0.0, -9.81]},
    "bodies.box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0.5, 0.0, 0.05],
                   "rgba": [1.0, 0.0, 0.0, 1.0], "restitution": 0.2, "lateral_friction": 0.8},
    "bodies.ball": {"shape": "sphere", "radius": 0.05, "mass": 0.2, "position": [0.0, 0.5, 0.05]},
    "robots.panda": {"urdf": "franka_panda/panda.urdf", "position": [0.0, 0.0, 0.0], "fixed_base": True},
    "sensors.scan": {"type": "lidar", "position": [0.0, 0.0, 0.3], "rays": 36, "fov_deg": 270.0,
                     "range_min": 0.05, "range_max": 3.0, "range_noise": 0.0},
    "sensors.ft": {"type": "force_torque", "body": "panda", "joint": "panda_hand_joint", "noise_std": 0.0},
    "actuators.hand": {"type": "gripper", "body": "panda", "force": 20.0, "gear_erp": 0.1, "empty_width": 0.004,
                       "settle_speed": 0.01},
    "actuators.arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget", "speed": 0.8,
                      "ik_iterations": 30, "position_gain": 0.3},
}

# (table, key, element index or None, type, bounds as docs/config-reference.md states them)
NUMBERS: list[tuple[str, str, int | None, str, dict[str, float]]] = [
    ("world", "time_step", None, "float", {"gt": 0, "le": 0.1}),
    ("world", "max_time", None, "float", {"gt": 0, "le": 1e6}),
    ("world", "solver_iterations", None, "int", {"ge": 1, "le": 1000}),
    ("world", "seed", None, "int", {"ge": 0}),
    *[("world", "gravity", i, "float", {"ge": -1000, "le": 1000}) for i in range(3)],
    ("bodies.box", "mass", None, "float", {"ge": 0, "le": 1e6}),
    *[("bodies.box", "size", i, "float", {"gt": 0, "le": 1000}) for i in range(3)],
    ("bodies.box", "restitution", None, "float", {"ge": 0, "le": 1}),
    ("bodies.box", "lateral_friction", None, "float", {"ge": 0, "le": 100}),
    ("bodies.ball", "radius", None, "float", {"gt": 0, "le": 1000}),
    *[("bodies.ball", "position", i, "float", {"ge": -1e4, "le": 1e4}) for i in range(3)],
    ("sensors.scan", "rays", None, "int", {"ge": 1, "le": 16384}),
    ("sensors.scan", "fov_deg", None, "float", {"gt": 0, "le": 360}),
    ("sensors.scan", "range_min", None, "float", {"ge": 0}),
    ("sensors.scan", "range_max", None, "float", {"gt": 0}),
    ("sensors.scan", "range_noise", None, "float", {"ge": 0}),
    ("sensors.ft", "noise_std", None, "float", {"ge": 0}),
    ("actuators.hand", "force", None, "float", {"gt": 0}),
    ("actuators.hand", "gear_erp", None, "float", {"gt": 0, "le": 1}),
    ("actuators.hand", "empty_width", None, "float", {"ge": 0}),
    ("actuators.hand", "settle_speed", None, "float", {"gt": 0}),
    ("actuators.arm", "speed", None, "float", {"gt": 0}),
    ("actuators.arm", "ik_iterations", None, "int", {"ge": 1, "le": 1000}),
    ("actuators.arm", "position_gain", None, "float", {"gt": 0, "le": 1}),
]
PLUGINS = load_plugins()
WORDS = {"ge": "greater than or equal to", "gt": "greater than", "le": "less than or equal to"}


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(v)


def write(path: Path, tables: dict[str, dict[str, Any]]) -> None:
    path.write_text("".join(f"[{name}]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in table.items()) + "\n"
                            for name, table in tables.items()), encoding="utf-8")


def validate(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    code = main(["validate", str(path)])
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 or code == 0, err  # one line, whatever went wrong
    return code, err.strip()


def bound_text(b: float) -> tuple[str, ...]:
    return (str(int(b)), repr(float(b))) if float(b).is_integer() else (repr(float(b)),)


def load(path: Path) -> tuple[int, str]:
    """``(0, "")`` if the file loads as a config (without building its world: cheap), else ``(2, the error line)``
    as the command line prints it."""
    try:
        load_config(path, PLUGINS)
    except ConfigError as exc:
        return 2, f"robokit: error: {exc}"
    return 0, ""


def test_the_base_config_is_valid(tmp_path: Path) -> None:
    path = tmp_path / "base.toml"
    write(path, BASE)
    assert load(path) == (0, "")


@CLI
@given(st.sampled_from(NUMBERS), st.sampled_from(["bool", "string", "nan", "inf", "-inf", "below", "above"]),
       st.floats(0.001, 3.0))
def test_a_wrong_number_names_the_file_the_key_path_the_rule_and_the_value(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], entry: tuple, kind: str, past: float) -> None:
    table, key, index, kind_of_number, bounds = entry
    base = BASE[table][key] if index is None else BASE[table][key][index]
    if kind in ("nan", "inf", "-inf") and kind_of_number == "int":
        kind = "string"
    if kind == "below" and not ({"ge", "gt"} & set(bounds)):
        kind = "bool"
    if kind == "above" and "le" not in bounds:
        kind = "string"
    low = bounds.get("ge", bounds.get("gt"))
    step = math.ceil(past) if kind_of_number == "int" else past
    value: Any = {"bool": True, "string": str(base), "nan": math.nan, "inf": math.inf, "-inf": -math.inf,
                  "below": (low - step) if low is not None else None,
                  "above": bounds["le"] + step if "le" in bounds else None}[kind]
    if kind == "below" and "gt" in bounds and kind_of_number == "float" and past > 2.0:
        value = float(bounds["gt"])  # on the bound itself, which 'greater than' refuses
    if kind_of_number == "int" and kind in ("below", "above"):
        value = int(value)
    tables = {name: dict(t) for name, t in BASE.items()}
    if index is None:
        tables[table][key] = value
    else:
        vector = list(tables[table][key])
        vector[index] = value
        tables[table][key] = vector
    path = tmp_path / "wrong.toml"
    write(path, tables)

    code, line = validate(path, capsys)
    where = f"{table}.{key}" + ("" if index is None else f".{index}")
    assert code == 2
    assert line.startswith(f"robokit: error: {path}: {where}: "), line
    message = line[len(f"robokit: error: {path}: {where}: "):]
    assert message.endswith(f", got {value!r}"), message
    if kind in ("bool", "string"):
        assert ("valid integer" if kind_of_number == "int" else "valid number") in message
    elif kind in ("nan", "inf", "-inf"):
        assert "finite number" in message
    else:
        broken = [rule for rule, b in bounds.items()
                  if not {"ge": value >= b, "gt": value > b, "le": value <= b}[rule]]
        assert broken, (value, bounds)
        rule = broken[0]
        assert any(f"{WORDS[rule]} {b}" in message for b in bound_text(bounds[rule])), message


def typos(word: str) -> st.SearchStrategy[str]:
    """One slip of the keyboard: a letter dropped, doubled, or two neighbours swapped."""
    n = len(word)
    return st.one_of(
        st.integers(0, n - 1).map(lambda i: word[:i] + word[i + 1:]),
        st.integers(0, n - 1).map(lambda i: word[:i] + word[i] + word[i:]),
        st.integers(0, n - 2).map(lambda i: word[:i] + word[i + 1] + word[i] + word[i + 2:]),
    )


@CLI
@given(st.data(), st.sampled_from([(t, k) for t, table in BASE.items() for k in table if k != "type"]))
def test_a_misspelt_key_is_named_with_the_key_it_is_closest_to_and_the_valid_keys(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], data: Any, entry: tuple[str, str]) -> None:
    table, key = entry
    typo = data.draw(typos(key).filter(lambda t: t != key and t not in BASE[table] and t.strip("_")))
    tables = {name: dict(t) for name, t in BASE.items()}
    tables[table] = {(typo if k == key else k): v for k, v in tables[table].items()}
    path = tmp_path / "typo.toml"
    write(path, tables)

    code, line = validate(path, capsys)
    assert code == 2, f"{typo!r} for {key!r} was accepted"  # a misspelt key is refused, even one with a default
    prefix = f"robokit: error: {path}: "
    assert line.startswith(prefix), line
    rest = line[len(prefix):]
    if rest.startswith(f"{table}.{key}: "):  # a required key goes missing first: the line names it
        assert "required" in rest.lower() or "missing" in rest.lower(), rest
        return
    assert rest.startswith(f"{table}.{typo}: unknown key {typo!r} (did you mean "), rest
    suggested = rest.split("(did you mean ", 1)[1].split("?)", 1)[0].strip("'")
    valid = rest.split("; valid keys: ", 1)[1].split(", ")
    assert key in valid and suggested in valid and typo not in valid
    ratio = difflib.SequenceMatcher(None, typo, key).ratio()
    assert difflib.SequenceMatcher(None, typo, suggested).ratio() >= ratio - 1e-12  # no worse than the key meant
    assert valid == sorted(valid)


# ------------------------------------------------------------------------------------------ [randomize]
# docs/randomize.md: "a reversed range, a restitution outside 0-1, an unknown sensor in dropout, an unknown setting in
# params (with the plugin's valid ones) ... are each one line naming the key"; factors and damping are not negative
RANGES = {"mass_scale": (0.0, None), "friction_scale": (0.0, None), "restitution": (0.0, 1.0),
          "joint_damping": (0.0, None), "light_azimuth_deg": (None, None), "light_elevation_deg": (None, None)}
ends = st.sampled_from([-0.5, 0.0, 0.3, 1.0, 1.5, 2.0])


@PROPS
@given(st.sampled_from(sorted(RANGES)), ends, ends)
def test_a_randomize_range_is_refused_exactly_when_reversed_or_out_of_its_bounds(
        tmp_path: Path, key: str, low: float, high: float) -> None:
    tables = {name: dict(t) for name, t in BASE.items()}
    tables["randomize"] = {key: [low, high]}
    path = tmp_path / "randomize.toml"
    write(path, tables)
    code, line = load(path)
    lo_bound, hi_bound = RANGES[key]
    if low > high:
        assert code == 2
        assert line == (f"robokit: error: {path}: randomize: {key} [{low!r}, {high!r}]: the first value must be "
                        "<= the second")
    elif lo_bound is not None and low < lo_bound:
        assert code == 2
        assert line == f"robokit: error: {path}: randomize: {key} [{low!r}, {high!r}]: values must be >= {lo_bound:g}"
    elif hi_bound is not None and high > hi_bound:
        assert code == 2
        assert line == f"robokit: error: {path}: randomize: {key} [{low!r}, {high!r}]: values must be <= {hi_bound:g}"
    else:
        assert code == 0, line


@PROPS
@given(ends, ends, st.sampled_from(["scan", "ft", "scna", "hand", "cam"]))
def test_a_dropout_is_a_probability_range_of_a_sensor_there_is(
        tmp_path: Path, low: float, high: float, sensor: str) -> None:
    tables = {name: dict(t) for name, t in BASE.items()}
    tables["randomize.dropout"] = {sensor: [low, high]}
    path = tmp_path / "dropout.toml"
    write(path, tables)
    code, line = load(path)
    head = f"robokit: error: {path}: randomize.dropout.{sensor}"
    bad = [i for i, v in enumerate((low, high)) if not 0.0 <= v <= 1.0]
    if bad:
        word = "greater than or equal to 0" if (low, high)[bad[0]] < 0 else "less than or equal to 1"
        assert line == f"{head}.{bad[0]}: input should be {word}, got {(low, high)[bad[0]]!r}"
    elif low > high:
        assert line == (f"robokit: error: {path}: randomize: dropout.{sensor} [{low!r}, {high!r}]: the first value "
                        "must be <= the second")
    elif sensor not in ("scan", "ft"):  # an actuator is not a sensor either
        hint = " (did you mean 'scan'?)" if sensor == "scna" else ""
        assert line == f"{head}: unknown sensor {sensor!r}{hint}; sensors: scan, ft"
    else:
        assert code == 0, line
        return
    assert code == 2


@PROPS
@given(st.data(), st.sampled_from([("sensors", "scan", "range_max"), ("sensors", "ft", "noise_std"),
                                   ("actuators", "hand", "force"), ("actuators", "arm", "speed")]))
def test_a_misspelt_randomized_setting_names_its_plugin_and_the_settings_it_has(
        tmp_path: Path, data: Any, entry: tuple[str, str, str]) -> None:
    section, name, key = entry
    table = BASE[f"{section}.{name}"]
    typo = data.draw(typos(key).filter(lambda t: t != key))
    tables = {n: dict(t) for n, t in BASE.items()}
    tables["randomize.params"] = {}
    path = tmp_path / "params.toml"
    text = "".join(f"[{n}]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in t.items()) + "\n"
                   for n, t in tables.items() if n != "randomize.params")
    path.write_text(text + f'[randomize.params]\n"{section}.{name}.{typo}" = {{ scale = [0.9, 1.1] }}\n',
                    encoding="utf-8")
    code, line = load(path)
    assert code == 2
    head = f"robokit: error: {path}: randomize.params.{section}.{name}.{typo}: unknown setting {typo!r} (did you mean "
    assert line.startswith(head), line
    assert f"?) of {table['type']} {name!r}; valid: " in line
    valid = line.split("; valid: ", 1)[1].split(", ")
    assert key in valid and set(k for k in table if k != "type") <= set(valid)
