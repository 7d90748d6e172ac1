"""A sweep's trials compared with the grid, seeds and rows they come from, over generated sweeps.

``--set KEY=V1,V2`` options and sweep files are generated (numbers, booleans, strings with commas, lists, bare
words; nested or dotted tables; seeds as ``"A:B"`` or ``[A, B]``), and every answer is worked out plainly here:
one value fixes a key, several make an axis; the cells are the product of the axes over the keys in sorted order,
each named by its values as JSON; the trials go cell by cell, seeds in order, each keyed ``<cell>/seed=<n>``;
``trials.jsonl`` read back is the last row of every key, a torn last line cut off the file; the progress lines
count what is done.
"""

from __future__ import annotations

import io
import itertools
import json
import math
import uuid
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.errors import UserError
from robokit.sweep.engine import read_trials
from robokit.sweep.progress import Progress
from robokit.sweep.spec import SweepSpec, load_sweep_file, parse_seeds, parse_set
from robokit.sweep.trial import trial_run_id

PROPS = settings(max_examples=40, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])

scalar = st.one_of(st.integers(-10**6, 10**6), st.floats(-1e6, 1e6, allow_nan=False).filter(lambda x: x == x),
                   st.booleans(), st.text("ab ,xy[]", max_size=5))
value = st.one_of(scalar, st.lists(scalar, max_size=3), st.text("xyz", min_size=1, max_size=3).map(lambda s: ("bare",
                                                                                                              s)))


def toml(v: Any) -> str:
    """A value written as TOML by hand (a bare word as it is)."""
    if isinstance(v, tuple):
        return v[1]
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return '"' + v + '"'
    return "[" + ", ".join(toml(x) for x in v) + "]"


def plain(v: Any) -> Any:
    """The value a TOML reader gives (a bare word, not TOML, is kept as its text)."""
    return v[1] if isinstance(v, tuple) else v


keys = st.sampled_from(["behaviour.speed", "world.seed", "bodies.box.mass", "behaviour.goal", "world.max_time"])
axes = st.dictionaries(keys, st.lists(value, min_size=1, max_size=3), min_size=0, max_size=3)


@PROPS
@given(axes, st.integers(0, 50), st.integers(1, 4))
def test_set_options_make_the_grid_and_the_trials_are_its_product_times_the_seeds(
        given_axes: dict[str, list[Any]], first: int, count: int) -> None:
    options = [f"{k}=" + ",".join(toml(v) for v in values) for k, values in given_axes.items()]
    grid, fixed = parse_set(options)
    assert fixed == {k: plain(v[0]) for k, v in given_axes.items() if len(v) == 1}
    assert grid == {k: tuple(plain(x) for x in v) for k, v in given_axes.items() if len(v) > 1}
    seeds = parse_seeds(f"{first}:{first + count}")
    spec = SweepSpec(config=Path("c.toml"), seeds=seeds, grid=grid, fixed=fixed)
    names = sorted(k for k, v in given_axes.items() if len(v) > 1)
    cells = []
    for combo in itertools.product(*(given_axes[k] for k in names)):
        values = [plain(v) for v in combo]
        key = ",".join(f"{k}={json.dumps(v, separators=(',', ':'))}" for k, v in zip(names, values, strict=True))
        cells.append((key or "base", {**fixed, **dict(zip(names, values, strict=True))}))
    assert spec.cells() == cells
    trials = spec.trials()
    assert [(t.key, t.cell, dict(t.overrides), t.seed) for t in trials] == [
        (f"{c}/seed={s}", c, o, s) for c, o in cells for s in range(first, first + count)]
    ids = {trial_run_id("6f1c2d3e-0000-4000-8000-000000000000", t.key) for t in trials}
    assert len(ids) == len({t.key for t in trials})  # a run id per trial, the same for the same key
    assert all(str(uuid.UUID(i)) == i for i in ids)


@pytest.mark.parametrize("item", ["speed", "=1", "speed=", "speed=  ", "a=1 --set a=2"])
def test_a_set_option_without_key_or_value_is_refused_naming_it(item: str) -> None:
    items = ["a=1", "a=2"] if item.startswith("a=1 ") else [item]
    with pytest.raises(UserError, match="given twice" if len(items) == 2 else "expected KEY=V1,V2"):
        parse_set(items)


@given(st.integers(-5, 60), st.integers(-5, 60), st.sampled_from(["A:B", "N", "A:B:C", "x", "A:"]))
@settings(max_examples=60, deadline=None, derandomize=True)
def test_seeds_are_a_python_range_or_one_seed(a: int, b: int, form: str) -> None:
    text = {"A:B": f"{a}:{b}", "N": f"{a}", "A:B:C": f"{a}:{b}:1", "x": "x", "A:": f"{a}:"}[form]
    want = range(a, b) if form == "A:B" else range(a, a + 1) if form == "N" else None
    if want is None or want.start < 0 or len(want) == 0:
        with pytest.raises(UserError) as err:
            parse_seeds(text, "sweep.toml: seeds")
        assert str(err.value).startswith("sweep.toml: seeds: expected") and repr(text) in str(err.value)
    else:
        assert parse_seeds(text) == want


@PROPS
@given(axes.filter(lambda a: all(len(v) > 1 for v in a.values())), st.dictionaries(keys, value, max_size=2),
       st.booleans(), st.booleans(), st.integers(0, 9), st.lists(st.sampled_from(["placed", "sim_time"]),
                                                                 unique=True))
def test_a_sweep_file_is_read_as_the_same_options_would_be(
        tmp_path_factory: pytest.TempPathFactory, grid_axes: dict[str, list[Any]], sets: dict[str, Any],
        nested: bool, seeds_as_list: bool, first: int, metrics: list[str]) -> None:
    """Paths relative to the sweep file; ``[grid]`` and ``[set]`` written as dotted keys or nested tables."""
    root = tmp_path_factory.mktemp("sweep")
    folder = root / "configs" / "sweeps"
    folder.mkdir(parents=True)
    lines = ['config = "../robot.toml"', f"seeds = [{first}, {first + 3}]" if seeds_as_list else
             f'seeds = "{first}:{first + 3}"', f"metrics = {toml(metrics)}", 'out = "../../sweeps/mine"',
             "workers = 2"]
    for table, items in (("grid", {k: v for k, v in grid_axes.items()}), ("set", sets)):
        if nested:
            for head in sorted({k.split(".")[0] for k in items}):
                lines.append(f"[{table}.{head}]")
                lines += [f'"{k.split(".", 1)[1]}" = {toml(v)}' for k, v in items.items() if k.split(".")[0] == head]
        else:
            lines.append(f"[{table}]")
            lines += [f'"{k}" = {toml(v)}' for k, v in items.items()]
    path = folder / "speed.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    try:
        spec, options = load_sweep_file(path)
    except Exception as exc:  # a bare word is not TOML: the file is refused by its reader, naming the file
        assert any(isinstance(v, tuple) or isinstance(v, list) and any(isinstance(x, tuple) for x in v)
                   for v in [*sets.values(), *itertools.chain(*grid_axes.values())]), exc
        return
    assert spec.config == root / "configs" / "robot.toml" and spec.sweep_file == path
    assert spec.seeds == range(first, first + 3)
    assert dict(spec.grid) == {k: tuple(v) for k, v in grid_axes.items()}
    assert dict(spec.fixed) == sets
    assert spec.metrics == tuple(metrics) and spec.plugins == ()
    assert options == {"workers": 2, "out": str(root / "sweeps" / "mine")}


rows = st.lists(st.tuples(st.sampled_from(["base/seed=0", "base/seed=1", "v=2/seed=0"]),
                          st.sampled_from(["succeeded", "failed", "error"])), max_size=8)


@PROPS
@given(rows, st.sampled_from(["", '{"key": "base/seed=9", "outc', '{"key"']))
def test_trials_read_back_are_the_last_row_of_each_key_and_a_torn_line_is_cut_off(
        tmp_path_factory: pytest.TempPathFactory, written: list[tuple[str, str]], torn: str) -> None:
    path = tmp_path_factory.mktemp("out") / "trials.jsonl"
    whole = "".join(json.dumps({"key": k, "outcome": o, "n": i}) + "\n" for i, (k, o) in enumerate(written))
    path.write_bytes((whole + torn).encode("utf-8"))
    want: dict[str, dict[str, Any]] = {}
    for i, (k, o) in enumerate(written):
        want[k] = {"key": k, "outcome": o, "n": i}
    assert read_trials(path) == want
    assert path.read_bytes() == whole.encode("utf-8")  # the torn line is gone from the file too
    assert read_trials(path.with_name("absent.jsonl")) == {}


@PROPS
@given(st.integers(1, 60), st.data())
def test_progress_lines_count_what_is_done(total: int, data: st.DataObject) -> None:
    """Plain lines (not a terminal): one every twentieth of what is left to run, and one at the end; each says
    done/total and how many did not succeed; a resumed sweep says so first."""
    done = data.draw(st.integers(0, total - 1))
    failed = data.draw(st.integers(0, done))
    outcomes = data.draw(st.lists(st.sampled_from(["succeeded", "failed", "aborted"]), min_size=total - done,
                                  max_size=total - done))
    stream = io.StringIO()
    bar = Progress(total, done, failed, stream)
    every = max(1, (total - done) // 20)
    want = [f"sweep: {done}/{total} trials already done, resuming"] if done else []
    n, bad = done, failed
    for k, outcome in enumerate(outcomes, start=1):
        bar.update({"outcome": outcome, "wall_time": 0.0})
        n, bad = n + 1, bad + (outcome != "succeeded")
        if k % every == 0 or n == total:
            want.append(f"sweep: {n}/{total} done, {bad} not succeeded")
    bar.close()
    got = stream.getvalue().splitlines()
    assert len(got) == len(want)
    for line, head in zip(got, want, strict=True):
        assert line == head or line.startswith(head + ", ")
    assert (bar.done, bar.failed) == (total, bad)


# ------------------------------------------------------------------------------------------ one trial, in-process
@pytest.mark.slow  # a world built and run per example: ~0.2 s each
@settings(max_examples=10, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(0, 4), st.sampled_from([0.05, 0.3, 2.0]), st.lists(st.integers(0, 4), max_size=2),
       st.sampled_from([0.5, 1.0]), st.sampled_from(["none", "failed", "all"]), st.booleans())
def test_a_trials_row_is_its_own_run(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch,
                                     seed: int, duration: float, raise_seeds: list[int], max_time: float, keep: str,
                                     misspelt: bool) -> None:
    """Every field of a trial's row: the task's key, cell, overrides, seed and run id; the outcome the test
    behaviour must reach (it raises on its raise seeds at 0.05 s, succeeds at ``duration``, else runs out of time);
    its figure from its own seed; the sim time in whole ticks; the record kept as ``keep`` says, holding the same."""
    from robokit.sweep.trial import TrialTask, run_trial

    plugins = Path(__file__).resolve().parent / "sweep_plugins"
    monkeypatch.syspath_prepend(str(plugins))
    overrides = {"behaviour.duration": duration, "behaviour.raise_seeds": raise_seeds, "world.max_time": max_time}
    if misspelt:
        overrides["behaviour.duratoin"] = 1.0
    records = tmp_path_factory.mktemp("records")
    run_id = trial_run_id("6f1c2d3e-0000-4000-8000-000000000000", f"c/seed={seed}")
    task = TrialTask(key=f"c/seed={seed}", cell="c", overrides=overrides, seed=seed, run_id=run_id,
                     config_text=(plugins / "fault.toml").read_text(), source="fault.toml", base_dir=str(plugins),
                     plugins=("sweep_faults",), keep=keep, record_dir=str(records))
    row = run_trial(task)
    assert (row["key"], row["cell"], row["overrides"], row["seed"], row["run_id"]) == (
        f"c/seed={seed}", "c", overrides, seed, run_id)
    if misspelt:  # refused before anything runs: one line naming the key
        assert row["outcome"] == "error" and row["reason"].startswith("config: ") and "duratoin" in row["reason"]
        assert row["figures"] == {} and row["sim_time"] is None and not list(records.iterdir())
        return
    if seed in raise_seeds:
        outcome, end = "error", 0.05
    elif duration <= max_time:
        outcome, end = "succeeded", duration
    else:
        outcome, end = "aborted", max_time
    assert row["outcome"] == outcome, row["reason"]
    assert row["figures"]["seed_squared"] == seed * seed
    assert row["ticks"] == math.ceil(end * 240 - 1e-9) + (outcome != "aborted") or row["ticks"] == round(end * 240)
    assert row["sim_time"] == pytest.approx(row["ticks"] / 240, abs=1e-6)  # kept to the microsecond
    assert row["result"]["outcome"] == outcome and row["result"]["seed"] == seed
    kept = keep == "all" or keep == "failed" and outcome != "succeeded"
    assert ("record" in row) == kept and (records / run_id).is_dir() == kept
    if kept:
        saved = json.loads((records / run_id / "result.json").read_text())
        assert (saved["outcome"], saved["seed"], saved["ticks"]) == (outcome, seed, row["ticks"])
        lines = (records / run_id / "trace.jsonl").read_text().splitlines()
        assert json.loads(lines[-1])["kind"] == "end" and json.loads(lines[-1])["outcome"] == outcome
