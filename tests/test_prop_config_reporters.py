"""``[report]`` sections, generated: valid ones reach the built reporters, each mistake is one line at its key.

What docs/configs.md, docs/reporting.md ("``[report.http]`` reference") and docs/config-reference.md promise,
written out below as plain tables: ``[report]`` takes ``student``, ``project``, ``keep_local`` (default true) and
one sub-table per reporter; the ``local`` reporter is always on unless ``keep_local = false`` (a ``[report.local]``
table asks for it by itself), its ``dir`` defaults to ``results``; ``[report.http]`` takes a required ``url`` and
the keys of the reference table with their defaults and bounds. Every mistake is one line naming the file and the
key path, an unknown key or reporter with a "did you mean".

A valid ``[report]`` is written as TOML, loaded, and its reporters built (``robokit.runner.make_reporters``); what
is compared is read from the built reporters -- their names in order, their settings, and for ``http`` the options
it sends with and the retry policy of the HTTP session it makes -- never from the parsed dict.
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
from robokit.runner import make_reporters

# key -> (kind, bounds, default) from docs/reporting.md's and docs/config-reference.md's tables
HTTP: dict[str, tuple[str, dict[str, Any], Any]] = {
    "url": ("url", {}, "required"),
    "token_env": ("env", {}, None),
    "connect_timeout": ("float", {"gt": 0}, 3.05),
    "read_timeout": ("float", {"gt": 0}, 10.0),
    "retries": ("int", {"ge": 0, "le": 20}, 4),
    "backoff_factor": ("float", {"ge": 0}, 0.5),
    "backoff_max": ("float", {"ge": 0}, 30.0),
    "backoff_jitter": ("float", {"ge": 0}, 0.5),
    "retry_after_max": ("float", {"ge": 0}, 120.0),
    "verify": ("verify", {}, True),
    "max_payload_bytes": ("int", {"ge": 1}, 1_000_000),
    "outbox": ("text", {}, "outbox"),
    "flush_outbox": ("bool", {}, True),
    "upload_artifacts": ("bool", {}, False),
    "artifacts_dir": ("text", {}, "results"),
}
LOCAL: dict[str, tuple[str, dict[str, Any], Any]] = {"dir": ("text", {}, "results")}
REPORTERS = {"http": HTTP, "local": LOCAL}
REPORT = {"student": ("name", {}, None), "project": ("name", {}, None), "keep_local": ("bool", {}, True)}

PROPS = settings(max_examples=25, deadline=None, derandomize=True, database=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])

text = st.text(st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]), min_size=1, max_size=12)


def _value(draw: Any, kind: str, bounds: dict[str, Any]) -> Any:
    if kind == "int":
        return draw(st.integers(bounds.get("ge", 0), bounds.get("le", 10**6)))
    if kind == "float":
        low = bounds.get("ge", bounds.get("gt", 0))
        return draw(st.one_of(st.integers(low + 1, 1000),  # an integer is fine for a float
                              st.floats(low, 1e4, allow_nan=False, exclude_min="gt" in bounds)))
    if kind == "bool":
        return draw(st.booleans())
    if kind == "url":
        return draw(st.sampled_from(["http://127.0.0.1:8000/api/robotics/result/", "https://school.example/r/",
                                     "http://192.168.0.10:8000/api/robotics/result/"]))
    if kind == "env":
        return draw(st.from_regex(r"[A-Z_][A-Z0-9_]{0,10}", fullmatch=True))
    if kind == "verify":
        import certifi  # a CA bundle that exists (requests' own)

        return draw(st.one_of(st.booleans(), st.just(certifi.where())))
    return draw(text.filter(str.strip))


@st.composite
def report_table(draw: Any) -> dict[str, Any]:
    """A ``[report]`` table: its own keys and reporter sub-tables, each key present or not, in a drawn order."""
    table: dict[str, Any] = {}
    for key, (kind, bounds, _) in REPORT.items():
        if draw(st.booleans()):
            table[key] = _value(draw, kind, bounds)
    for name in draw(st.permutations(sorted(REPORTERS))):
        if not draw(st.booleans()):
            continue
        sub = {}
        for key, (kind, bounds, default) in REPORTERS[name].items():
            if default == "required" or draw(st.booleans()):
                sub[key] = _value(draw, kind, bounds)
        table[name] = sub
    return table


def toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return '"' + "".join(c if c not in '"\\' else "\\" + c for c in value) + '"'
    raise TypeError(value)


def write_config(folder: Path, report: dict[str, Any]) -> Path:
    """The report table as people write it: ``[report]`` scalars, then a ``[report.NAME]`` table per reporter."""
    lines = ["[world]", "max_time = 1.0", "[bodies.box]", 'shape = "box"', "size = [0.1, 0.1, 0.1]", "mass = 1.0",
             "position = [0.0, 0.0, 0.05]", "[report]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in report.items() if not isinstance(v, dict)]
    for name, sub in report.items():
        if isinstance(sub, dict):
            lines += [f"[report.{name}]", *(f"{k} = {toml_value(v)}" for k, v in sub.items())]
    path = folder / "report.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def expected(report: dict[str, Any]) -> dict[str, Any]:
    """The reporters the docs' rules give, in order, each with every setting (given or the documented default)."""
    names = [n for n in report if isinstance(report[n], dict)]
    if report.get("keep_local", True) and "local" not in names:
        names.insert(0, "local")
    return {"report": {k: report.get(k, default) for k, (_, _, default) in REPORT.items()},
            "reporters": [(n, {k: report.get(n, {}).get(k, d) for k, (_, _, d) in REPORTERS[n].items()})
                          for n in names],
            "sends": {n: _sends(report[n]) for n in names if n == "http"}}


def _sends(http: dict[str, Any]) -> dict[str, Any]:
    get = {k: http.get(k, d) for k, (_, _, d) in HTTP.items()}
    return {"retries": get["retries"], "backoff_factor": get["backoff_factor"], "backoff_max": get["backoff_max"],
            "connect_timeout": get["connect_timeout"], "read_timeout": get["read_timeout"],
            "verify": get["verify"], "max_payload_bytes": get["max_payload_bytes"], "token_env": get["token_env"],
            "upload_artifacts": get["upload_artifacts"], "artifacts_dir": get["artifacts_dir"]}


def observed(path: Path, plugins: Any) -> dict[str, Any]:
    """The same, read from the loaded config's ``report`` and the reporters built from it."""
    from robokit_plugins.http_report import HttpOptions, make_session

    cfg = load_config(path, plugins)
    built = make_reporters(cfg, plugins)
    sends = {}
    for r in built:
        if r.name == "http":
            opts = HttpOptions.from_mapping(r.config)
            retry = make_session(opts).get_adapter("http://x/").max_retries
            sends["http"] = {"retries": retry.total, "backoff_factor": retry.backoff_factor,
                             "backoff_max": retry.backoff_max, "connect_timeout": opts.connect_timeout,
                             "read_timeout": opts.read_timeout, "verify": opts.verify,
                             "max_payload_bytes": opts.max_payload_bytes, "token_env": opts.token_env,
                             "upload_artifacts": opts.upload_artifacts, "artifacts_dir": opts.artifacts_dir}
    return {"report": {k: getattr(cfg.report, k) for k in REPORT},
            "reporters": [(r.name, {k: getattr(r.config, k) for k in REPORTERS[r.name]}) for r in built],
            "sends": sends}


@pytest.fixture(scope="module")
def plugins() -> Any:
    return load_plugins()


@settings(PROPS, max_examples=4)
@given(report_table())
def test_a_valid_report_table_reaches_the_built_reporters_with_every_value_given(tmp_path: Path, plugins: Any,
                                                                                 report: dict[str, Any]) -> None:
    assert observed(write_config(tmp_path, report), plugins) == expected(report)


@pytest.mark.slow
@settings(PROPS, max_examples=150)
@given(report_table())
def test_many_valid_report_tables_reach_the_built_reporters(tmp_path: Path, plugins: Any,
                                                            report: dict[str, Any]) -> None:
    assert observed(write_config(tmp_path, report), plugins) == expected(report)


# ----------------------------------------------------------------------------------------------- one mistake each
def misspelt(word: str, i: int) -> str:
    j = 1 + i % (len(word) - 2)
    return word[:j] + word[j + 1:]


def wrong_values(kind: str, bounds: dict[str, Any]) -> list[Any]:
    """Values the docs refuse for a key of this kind: another type, and just past each bound."""
    out: list[Any] = {"int": ["3", 2.5, True], "float": ["1.0", True], "bool": ["yes", 1],
                      "url": ["", "ftp://school/r/", 3], "env": ["my token", "1ABC", 3],
                      "verify": [3, "no/such/ca.pem"], "text": ["", 3], "name": [3, True]}[kind]
    if "ge" in bounds:
        out.append(bounds["ge"] - 1 if kind == "int" else bounds["ge"] - 0.5)
    if "gt" in bounds:
        out.append(bounds["gt"])
    if "le" in bounds:
        out.append(bounds["le"] + 1)
    return out


MISTAKES = ["report key", "report value", "reporter name", "reporter key", "reporter value", "not a table"]


def plant(data: Any, report: dict[str, Any], mistake: str) -> tuple[str, str]:
    """One mistake in ``report`` (in place): the key path its error must name and a text the line must have."""
    subs = [n for n in report if isinstance(report[n], dict)]
    if mistake == "reporter name" or (mistake.startswith("reporter") and not subs):
        name = data.draw(st.sampled_from(sorted(REPORTERS)))
        bad = misspelt(name, data.draw(st.integers(0, 5)))
        report[bad] = report.pop(name, {"url": "http://127.0.0.1/"} if name == "http" else {})
        return f"report.{bad}", f"(did you mean {name!r}?)"
    if mistake == "not a table":
        name = data.draw(st.sampled_from(sorted(REPORTERS)))
        report[name] = data.draw(st.sampled_from(["x", 3, True]))
        return f"report.{name}", "expected a table"
    if mistake == "report key":
        good = data.draw(st.sampled_from(sorted(REPORT)))
        bad = misspelt(good, data.draw(st.integers(0, 10)))
        report.pop(good, None)
        report[bad] = "A"
        return f"report.{bad}", f"(did you mean {good!r}?)"
    if mistake == "report value":
        key = data.draw(st.sampled_from(sorted(REPORT)))
        report[key] = data.draw(st.sampled_from(wrong_values(*REPORT[key][:2])))
        return f"report.{key}", ""
    name = data.draw(st.sampled_from(subs))
    table = REPORTERS[name]
    if mistake == "reporter key":
        good = data.draw(st.sampled_from(sorted(table)))
        bad = misspelt(good, data.draw(st.integers(0, 10)))
        if bad in table:
            bad = good + "s"
        report[name][bad] = report[name].pop(good, "x")
        return f"report.{name}.{bad}", f"(did you mean {good!r}?)"
    key = data.draw(st.sampled_from(sorted(table)))
    report[name][key] = data.draw(st.sampled_from(wrong_values(*table[key][:2])))
    return f"report.{name}.{key}", ""


def _one_mistake(tmp_path: Path, plugins: Any, data: Any, report: dict[str, Any]) -> None:
    """Each kind of mistake in turn, planted alone in a copy of the table."""
    import copy

    for mistake in MISTAKES:
        table = copy.deepcopy(report)
        key, must = plant(data, table, mistake)
        path = write_config(tmp_path, table)
        with pytest.raises(ConfigError) as info:
            load_config(path, plugins)
        line = str(info.value)
        assert "\n" not in line, line
        assert line.startswith(f"{path}: {key}: "), (mistake, line, key)
        assert must in line, (mistake, line, must)


@settings(PROPS, max_examples=4)
@given(st.data(), report_table())
def test_one_mistake_in_a_report_table_is_one_line_naming_the_file_and_its_key(
        tmp_path: Path, plugins: Any, data: Any, report: dict[str, Any]) -> None:
    _one_mistake(tmp_path, plugins, data, report)


@pytest.mark.slow
@settings(PROPS, max_examples=100)
@given(st.data(), report_table())
def test_many_mistakes_in_report_tables_are_each_one_line_naming_the_file_and_its_key(
        tmp_path: Path, plugins: Any, data: Any, report: dict[str, Any]) -> None:
    _one_mistake(tmp_path, plugins, data, report)
