"""Behaviour sections, generated: trees of composites and leaves written as TOML, valid and with one mistake each.

What docs/configs.md, docs/behaviours.md ("Composites") and docs/config-reference.md promise, written out below as
plain tables: a ``[behaviour]`` takes ``type``, ``rate_hz`` (Hz dividing the physics rate) and its type's own keys;
a composite's children are ``[[behaviour.steps]]`` (sequence), ``[[behaviour.children]]`` (fallback: one or more;
parallel: two or more) or ``[behaviour.child]`` (retry, timeout: exactly one), each a behaviour section of its own
that may also take ``name`` (a string; default the type) and ``must_last`` (a bool), composites nesting. Types
are strict and numbers within their bounds; every mistake is one line naming the file and the key path
(``behaviour.steps[0].child.duration``), an unknown key with a "did you mean".

A valid tree is built into a simulation and read back from the built objects -- each behaviour instance's class
and config, each child's name, period in ticks and ``must_last`` -- never from the parsed dict. A tree with one
mistake planted is refused with the one line naming the place of the mistake.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.config import load_config
from robokit.errors import ConfigError
from robokit.plugin_api.plugins import load_plugins

PHYSICS_HZ = 240  # [world] time_step's default, 1/240 s
RATES = [240, 120, 80, 60, 48, 40, 30, 24, 20, 16, 15, 12, 10, 8, 6, 5, 4, 3, 2, 1, 240 / 7, 2.5]

# type -> {key: (kind, bounds, default)}; "required" when the docs give no default (config-reference.md); "fixed"
# keys are never generated (they name the scene's components), only misspelt or given a wrong type
LEAVES: dict[str, dict[str, tuple[str, dict[str, float], Any]]] = {
    "record": {"components": ("fixed", {"value": ()}, ()), "duration": ("float", {"ge": 0}, 1.0),
               "max_array": ("int", {"ge": 0}, 64)},
    "drop_test": {"duration": ("float", {"gt": 0}, 5.0), "pose_sensor": ("fixed", {"value": "poses"}, "poses")},
}
# composite -> (children key, least, most or None, its own keys)
COMPOSITES: dict[str, tuple[str, int, int | None, dict[str, tuple[str, dict[str, Any], Any]]]] = {
    "sequence": ("steps", 1, None, {}),
    "fallback": ("children", 1, None, {}),
    "parallel": ("children", 2, None, {"success": ("choice", {"of": ("all", "one")}, "all"),
                                       "failure": ("choice", {"of": ("one", "all")}, "one")}),
    "retry": ("child", 1, 1, {"attempts": ("int", {"ge": 1, "le": 1000}, 3)}),
    "timeout": ("child", 1, 1, {"seconds": ("float", {"gt": 0}, "required")}),
}
OPTIONS = {**LEAVES, **{t: c[3] for t, c in COMPOSITES.items()}}
NAMES = ["grab", "wait", "첫째", "go on", "z9"]  # never a type name, nor a type's ``<type>_<n>``
BASE = {"world": {"max_time": 1.0},
        "bodies": {"box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0.0, 0.0, 0.05]}},
        "sensors": {"poses": {"type": "body_pose"}}}

PROPS = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


# ----------------------------------------------------------------------------------------------- generated trees
def _value(draw: Any, kind: str, bounds: dict[str, Any]) -> Any:
    if kind == "choice":
        return draw(st.sampled_from(bounds["of"]))
    if kind == "fixed":  # the scene's one pose sensor
        return bounds["value"]
    low = bounds.get("ge", bounds.get("gt", 0))
    high = bounds.get("le", 100)
    if kind == "int":
        return draw(st.integers(int(low) + (1 if "gt" in bounds else 0), int(high)))
    value = draw(st.one_of(st.integers(int(low) + 1, int(high)),  # an integer is fine for a float
                           st.floats(low, high, allow_nan=False, exclude_min="gt" in bounds)))
    return value


@st.composite
def tree(draw: Any, depth: int = 2, composite: bool = False) -> dict[str, Any]:
    """A behaviour table as TOML gives it: a leaf, or a composite with generated children (``composite``: the
    root is one)."""
    kinds = ([] if composite else list(LEAVES)) + (list(COMPOSITES) if depth > 0 else [])
    type_name = draw(st.sampled_from(kinds))
    node: dict[str, Any] = {"type": type_name}
    for key, (kind, bounds, default) in OPTIONS[type_name].items():
        if kind != "fixed" and (default == "required" or draw(st.booleans())):  # "fixed": left at its default
            node[key] = _value(draw, kind, bounds)
    if draw(st.booleans()):
        node["rate_hz"] = draw(st.sampled_from(RATES))
    if type_name in COMPOSITES:
        ckey, least, most, _ = COMPOSITES[type_name]
        count = draw(st.integers(least, most or 3))
        children = [draw(tree(depth - 1)) for _ in range(count)]
        names = draw(st.lists(st.sampled_from(NAMES), min_size=count, max_size=count, unique=True))
        for child, name in zip(children, names, strict=True):
            if draw(st.booleans()):
                child["name"] = name
            if draw(st.booleans()):
                child["must_last"] = draw(st.booleans())
        node[ckey] = children[0] if most == 1 else children
    return node


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def toml_table(path: str, table: dict[str, Any], header: str) -> list[str]:
    """``table`` under ``header`` the way people write it: scalars, then ``[path.sub]`` and ``[[path.list]]``."""
    lines = [header]
    subs = []
    for key, value in table.items():
        if isinstance(value, dict):
            subs += toml_table(f"{path}.{key}", value, f"[{path}.{key}]")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for item in value:
                subs += toml_table(f"{path}.{key}", item, f"[[{path}.{key}]]")
        else:
            lines.append(f"{key} = {toml_value(value)}")
    return lines + subs


def write_config(folder: Path, behaviour: dict[str, Any]) -> Path:
    """The base scene and ``behaviour`` as a TOML file (``{"__scalar__": v}``: ``behaviour = v``, no table)."""
    scalar = [f"behaviour = {toml_value(behaviour['__scalar__'])}"] if "__scalar__" in behaviour else []
    lines = [*scalar, "[world]", "max_time = 1.0", "[bodies.box]",
             *(f"{k} = {toml_value(v)}" for k, v in BASE["bodies"]["box"].items()), "[sensors.poses]",
             'type = "body_pose"', *([] if scalar else toml_table("behaviour", behaviour, "[behaviour]"))]
    path = folder / "generated.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def children_of(node: dict[str, Any]) -> tuple[str, list[dict[str, Any]]] | None:
    if node["type"] not in COMPOSITES:
        return None
    ckey, _, most, _ = COMPOSITES[node["type"]]
    raw = node[ckey]
    return ckey, ([raw] if most == 1 else raw)


def child_names(children: list[dict[str, Any]]) -> list[str]:
    """A child's name: its ``name``, else its type (``<type>_<n>``, counting from 1, when unnamed siblings share
    a type)."""
    unnamed = [c["type"] for c in children if "name" not in c]
    seen: dict[str, int] = {}
    out = []
    for c in children:
        if "name" in c:
            out.append(c["name"])
            continue
        seen[c["type"]] = seen.get(c["type"], 0) + 1
        out.append(c["type"] if unnamed.count(c["type"]) == 1 else f"{c['type']}_{seen[c['type']]}")
    return out


def expected(node: dict[str, Any], name: str, must_last: bool) -> dict[str, Any]:
    """What the built tree must hold for ``node``: its type, name, period in ticks, ``must_last``, every option
    (given or its documented default) and its children, in order."""
    rate = node.get("rate_hz")
    out = {"type": node["type"], "name": name, "period": round(PHYSICS_HZ / rate) if rate else 1,
           "must_last": must_last,
           "options": {k: node.get(k, default) for k, (_, _, default) in OPTIONS[node["type"]].items()},
           "children": []}
    found = children_of(node)
    if found:
        kids = found[1]
        out["children"] = [expected(c, n, c.get("must_last", False)) for c, n in zip(kids, child_names(kids),
                                                                                     strict=True)]
    return out


def observed(behaviour: Any, name: str, period: int, must_last: bool, types: dict[type, str]) -> dict[str, Any]:
    """The same, read from a built behaviour instance and its children's members."""
    type_name = types[type(behaviour)]
    return {"type": type_name, "name": name, "period": period, "must_last": must_last,
            "options": {k: getattr(behaviour.config, k) for k in OPTIONS[type_name]},
            "children": [observed(m.behaviour, m.name, m.period, m.spec.must_last, types)
                         for m in getattr(behaviour, "children", [])]}


@pytest.fixture(scope="module")
def plugins() -> Any:
    return load_plugins()


def _built(path: Path, plugins: Any) -> dict[str, Any]:
    from robokit.core.simulation import Simulation

    sim = Simulation(load_config(path, plugins), plugins)
    try:
        types = {t.cls: n for n, t in plugins.types["behaviour"].items()}
        return observed(sim.behaviour, sim.behaviour.name, sim.scheduler.behaviour_period, False, types)
    finally:
        sim.close()


def from_spec(spec: Any, must_last: bool = False) -> dict[str, Any]:
    """The same, read from the loaded config's behaviour specs (a tree of ``ComponentSpec``; no world built)."""
    return {"type": spec.type, "name": spec.name,
            "period": round(PHYSICS_HZ / spec.rate_hz) if spec.rate_hz else 1, "must_last": must_last,
            "options": {k: getattr(spec.params, k) for k in OPTIONS[spec.type]},
            "children": [from_spec(c, c.must_last) for c in spec.children]}


@settings(PROPS, max_examples=5)
@given(tree(composite=True))
def test_a_valid_tree_reaches_the_loaded_config_with_every_value_given(tmp_path: Path, plugins: Any,
                                                                       node: dict[str, Any]) -> None:
    """The cheap half of the next test, for the default tier: the loaded config's specs, not the built world."""
    assert from_spec(load_config(write_config(tmp_path, node), plugins).behaviour) == expected(node, "behaviour",
                                                                                               False)


@pytest.mark.slow  # a simulation built per example (~0.1 s each)
@settings(PROPS, max_examples=60)
@given(tree(depth=3))
def test_a_valid_tree_reaches_the_built_behaviours_with_every_value_given(tmp_path: Path, plugins: Any,
                                                                          node: dict[str, Any]) -> None:
    assert _built(write_config(tmp_path, node), plugins) == expected(node, "behaviour", False)


# ----------------------------------------------------------------------------------------------- one mistake each
def nodes(node: dict[str, Any], key: str = "behaviour", child: bool = False) -> list[tuple[str, dict[str, Any],
                                                                                           bool]]:
    """Every section of the tree: (its key path, its table, whether it is a composite's child), depth first."""
    out = [(key, node, child)]
    found = children_of(node)
    if found:
        ckey, kids = found
        single = COMPOSITES[node["type"]][2] == 1
        for i, c in enumerate(kids):
            out += nodes(c, f"{key}.{ckey}" if single else f"{key}.{ckey}[{i}]", True)
    return out


def misspelt(word: str, i: int) -> str:
    """``word`` with one inner letter dropped."""
    j = 1 + i % (len(word) - 2)
    return word[:j] + word[j + 1:]


MISTAKES = ["misspelt", "wrong type", "out of range", "unknown type", "children", "duplicate name", "bad name",
            "missing type", "not a table"]


def plant(data: Any, node: dict[str, Any], key: str, child: bool, mistake: str) -> tuple[str, str] | None:
    """Make one mistake in ``node`` (changed in place); the key path the error must name and a text it must have,
    or None when this mistake does not apply to this section."""
    type_name = node["type"]
    own = list(OPTIONS[type_name])
    takes = own + ["rate_hz"] + (["name", "must_last"] if child else [])
    if mistake == "misspelt":
        good = data.draw(st.sampled_from(takes))
        bad = misspelt(good, data.draw(st.integers(0, 10)))
        if bad in takes:
            return None
        node[bad] = node.pop(good, 1)
        # every key the section takes: its type's own, type and rate_hz, a child's name and must_last, the children
        valid = sorted([*takes, "type", *([COMPOSITES[type_name][0]] if type_name in COMPOSITES else [])])
        return f"{key}.{bad}", f"unknown key {bad!r} (did you mean {good!r}?); valid keys: {', '.join(valid)}"
    if mistake == "not a table":
        if key != "behaviour":
            return None
        node.clear()
        node["__scalar__"] = data.draw(st.sampled_from([3, "sort", True]))
        return key, "expected a table, got"
    if mistake == "wrong type":
        good = data.draw(st.sampled_from(takes))
        kind = OPTIONS[type_name][good][0] if good in OPTIONS[type_name] else ""
        node[good] = {"name": 3, "must_last": "yes"}.get(good, 1 if kind == "fixed" else "1")
        return f"{key}.{good}", ""
    if mistake == "out of range":
        choices = [("rate_hz", data.draw(st.sampled_from([7, 0, -30, 480, 1000])))]
        for k, (kind, bounds, _) in OPTIONS[type_name].items():
            if kind == "choice":
                choices.append((k, "some"))
            if "ge" in bounds:
                choices.append((k, bounds["ge"] - 1 if kind == "int" else bounds["ge"] - 0.5))
            if "gt" in bounds:
                choices.append((k, bounds["gt"]))
            if "le" in bounds:
                choices.append((k, bounds["le"] + 1))
        k, value = data.draw(st.sampled_from(choices))
        node[k] = value
        return f"{key}.{k}", ""
    if mistake == "unknown type":
        node["type"] = misspelt(type_name, data.draw(st.integers(0, 10)))
        return f"{key}.type", f"(did you mean {type_name!r}?)"
    if mistake == "missing type":
        del node["type"]
        return key, "missing 'type'"
    found = children_of(node)
    if mistake == "children" and found:
        ckey, kids = found
        least, most = COMPOSITES[type_name][1:3]
        if most == 1:
            node[ckey] = [kids[0], kids[0]]
        elif data.draw(st.booleans()):
            node[ckey] = kids[0]  # one [behaviour.steps] table where [[behaviour.steps]] tables are asked for
        elif least == 2:
            node[ckey] = kids[:1]
        else:
            node[ckey] = []
        # docs/behaviours.md: "a parallel needs children: 2 or more [[behaviour.children]] tables, each with a type"
        noun = "steps" if ckey == "steps" else ("a child" if most == 1 else "children")
        count = "one" if most == 1 else ("one or more" if least == 1 else f"{least} or more")
        what = f"[{key}.{ckey}] table" if most == 1 else f"[[{key}.{ckey}]] tables"
        return f"{key}.{ckey}", f"a {type_name} needs {noun}: {count} {what}, each with a type"
    if mistake == "bad name" and found:
        ckey, kids = found
        i = data.draw(st.integers(0, len(kids) - 1))
        kids[i]["name"] = data.draw(st.sampled_from([3, True, "", 2.5, ["a"]]))
        return (f"{key}.{ckey}" if COMPOSITES[type_name][2] == 1 else f"{key}.{ckey}[{i}]") + ".name", ""
    if mistake == "duplicate name" and found and len(found[1]) > 1:
        ckey, kids = found
        kids[-1]["name"] = child_names(kids)[0]
        names = child_names(kids)
        twice = [i for i, n in enumerate(names) if names.count(n) > 1]
        if not twice:
            return None
        return f"{key}.{ckey}[{twice[0]}].name", f"two steps are named {names[twice[0]]!r}; give each a distinct name"
    return None


def refusal(path: Path, plugins: Any) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(path, plugins)
    return str(info.value)


def _one_mistake(tmp_path: Path, plugins: Any, data: Any, node: dict[str, Any]) -> None:
    """Each kind of mistake in turn, planted alone in a copy of the tree at a drawn section that can have it."""
    import copy

    count = len(nodes(node))
    for mistake in MISTAKES:
        first = data.draw(st.integers(0, count - 1))
        for i in range(count):  # from a drawn section on, the first that can have this mistake
            tree_ = copy.deepcopy(node)
            where = nodes(tree_)[(first + i) % count]
            planted = plant(data, where[1], where[0], where[2], mistake)
            if planted is not None:
                break
        else:
            continue
        key, text = planted
        path = write_config(tmp_path, tree_)
        line = refusal(path, plugins)
        assert "\n" not in line, line
        assert line.startswith(f"{path}: {key}: "), (mistake, line, key)
        assert text in line, (mistake, line, text)


@settings(PROPS, max_examples=3)
@given(st.data(), tree(composite=True))
def test_one_mistake_anywhere_in_a_tree_is_one_line_naming_the_file_and_its_key(
        tmp_path: Path, plugins: Any, data: Any, node: dict[str, Any]) -> None:
    _one_mistake(tmp_path, plugins, data, node)


@pytest.mark.slow
@settings(PROPS, max_examples=40)
@given(st.data(), tree(depth=3))
def test_many_mistakes_in_deeper_trees_are_each_one_line_naming_the_file_and_its_key(
        tmp_path: Path, plugins: Any, data: Any, node: dict[str, Any]) -> None:
    _one_mistake(tmp_path, plugins, data, node)


# a tree with a section of every kind, for the test below: (key path, table, whether it is a child)
EVERY_KIND = {"type": "sequence", "steps": [
    {"type": "record", "name": "grab"},
    {"type": "parallel", "children": [{"type": "drop_test"}, {"type": "record"}]},
    {"type": "retry", "child": {"type": "timeout", "seconds": 2.0, "child": {"type": "record"}}},
    {"type": "fallback", "children": [{"type": "record"}]}]}


def test_every_key_of_every_kind_of_section_misspelt_is_named_with_its_sections_keys(tmp_path: Path,
                                                                                    plugins: Any) -> None:
    """Each key each section of a tree with every composite takes (its type's own, ``rate_hz``, a child's ``name``
    and ``must_last``), misspelt alone: one line at that key, the key meant, and exactly the section's keys; and
    each composite's children written the wrong way (one table for ``[[...]]``, two for one): the docs' line."""
    import copy

    wrong = []
    for index, (key, node, child) in enumerate(nodes(EVERY_KIND)):
        takes = list(OPTIONS[node["type"]]) + ["rate_hz"] + (["name", "must_last"] if child else [])
        for good in takes:
            tree_ = copy.deepcopy(EVERY_KIND)
            where = nodes(tree_)[index][1]
            bad = misspelt(good, 0)
            where[bad] = where.pop(good, 1)
            valid = sorted([*takes, "type", *([COMPOSITES[node["type"]][0]] if node["type"] in COMPOSITES else [])])
            want = (f"{key}.{bad}: unknown key {bad!r} (did you mean {good!r}?); valid keys: "
                    f"{', '.join(valid)}")
            path = write_config(tmp_path, tree_)
            if refusal(path, plugins) != f"{path}: {want}":
                wrong.append(f"{refusal(path, plugins)} != {want}")
        if node["type"] in COMPOSITES:
            ckey, least, most, _ = COMPOSITES[node["type"]]
            tree_ = copy.deepcopy(EVERY_KIND)
            where = nodes(tree_)[index][1]
            kids = where[ckey] if most != 1 else [where[ckey]]
            where[ckey] = [kids[0], kids[0]] if most == 1 else kids[0]
            noun = "steps" if ckey == "steps" else ("a child" if most == 1 else "children")
            count = "one" if most == 1 else ("one or more" if least == 1 else f"{least} or more")
            what = f"[{key}.{ckey}] table" if most == 1 else f"[[{key}.{ckey}]] tables"
            want = f"{key}.{ckey}: a {node['type']} needs {noun}: {count} {what}, each with a type"
            path = write_config(tmp_path, tree_)
            if refusal(path, plugins) != f"{path}: {want}":
                wrong.append(f"{refusal(path, plugins)} != {want}")
    assert not wrong, "\n".join(wrong)
