"""``robokit results list`` and ``results show`` compared, row by row and line by line, with the run folders they
read, over generated folders.

Results folders are generated (runs with a result, runs with a trace only, broken traces; configs with Korean,
full-width and combining characters, missing or odd figures) and every answer is worked out plainly here: which
runs are listed and in what order, each column's text from the run's own ``result.json`` (or its trace's header),
every column starting at the same terminal column on every line (widths from ``wcwidth``, not from robokit), the
result tree parsed back to the very result; a record's sim time from its result, else its ``end`` record, else its
last pose sample; each machine's stays, including a machine the header does not name.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from wcwidth import wcswidth

from robokit.record.format import RunRecord, run_folders
from robokit.record.layout import FRAMES_DIR, POSES_FILE, RESULT_FILE, TRACE_FILE
from robokit.record.results import frames_note, headline, list_runs, show_run, tree

PROPS = settings(max_examples=40, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
HEADER = {"kind": "header", "schema": "robokit.record/1", "machines": []}
TEXT = "ab/._ 시간Ａé\u0301"  # ASCII, Hangul and full-width (two columns), a combining accent (none)
COLUMNS = ["run", "started (UTC)", "config", "seed", "engine", "outcome", "sim s", "figures"]

scalars = st.one_of(st.integers(-99, 10**6), st.floats(-1e4, 1e4, allow_nan=False), st.booleans(), st.none(),
                    st.text(TEXT, max_size=4))
results = st.fixed_dictionaries(
    {},
    optional={"outcome": st.sampled_from(["succeeded", "failed", "aborted", "error"]),
              "started_at": st.sampled_from(["2026-03-01T10:20:30.123456+00:00", "2026-12-31T23:59:59"]),
              "config": st.text(TEXT, min_size=1, max_size=45).filter(lambda c: c[0] != "\u0301"),  # marks on a letter
              "seed": st.integers(0, 10**6),
              "engine": st.sampled_from(["pybullet", "mujoco", ""]), "engine_version": st.just("3.3.0"),
              "sim_time": st.one_of(st.floats(0, 1e4), st.integers(0, 99), st.just("n/a")),
              "reason": st.text(TEXT, max_size=8), "ticks": st.integers(0, 9999), "wall_time": st.floats(0, 9),
              "result": st.dictionaries(st.text("xyz", min_size=1, max_size=2), scalars, max_size=6)})
runs = st.lists(st.tuples(st.text("0123456789abcdef", min_size=10, max_size=12),
                          st.sampled_from(["result", "trace", "broken"]), results, st.integers(0, 10**6)),
                max_size=6, unique_by=lambda r: r[0])


def write_runs(root: Path, made: list[tuple[str, str, dict[str, Any], int]]) -> None:
    for i, (name, kind, result, seed) in enumerate(made):
        d = root / name
        d.mkdir(parents=True)
        if kind == "result":
            f = d / RESULT_FILE
            f.write_text(json.dumps(result, ensure_ascii=False), encoding="utf-8")
        elif kind == "trace":
            f = d / TRACE_FILE
            named = {"config_path": f"/abs/cfg{i}.toml", "seed": seed} if i % 2 == 0 else {}  # or a bare header
            f.write_text(json.dumps({**HEADER, **named}) + "\n", encoding="utf-8")
        else:
            f = d / TRACE_FILE
            f.write_text("not json\n", encoding="utf-8")
        os.utime(f, (1_000 + i, 1_000 + i))  # made in order: the first is the oldest


def shortened(text: str) -> str:
    """The longest tail of ``text`` that fits 29 columns after "...", when the whole does not fit 32."""
    if wcswidth(text) <= 32:
        return text
    for k in range(len(text) + 1):
        if wcswidth(text[k:]) <= 29:
            return "..." + text[k:]
    return "..."


def cut(line: str, start: int, width: int | None) -> str:
    """The characters of ``line`` from terminal column ``start`` on (``width`` columns, or to the end)."""
    out, col, kept = [], 0, False
    for ch in line:
        w = wcswidth(ch)
        kept = (kept if w == 0 else  # a combining mark goes with the character before it
                col >= start and (width is None or col < start + width))
        if kept:
            out.append(ch)
        col += w
    return "".join(out)


@settings(PROPS, max_examples=25)
@given(runs, st.sampled_from([0, 1, 3, 20]))
def test_every_row_of_the_list_is_its_runs_own_result(tmp_path_factory: pytest.TempPathFactory,
                                                      made: list[tuple[str, str, dict[str, Any], int]],
                                                      n: int) -> None:
    root = tmp_path_factory.mktemp("results")
    write_runs(root, made)
    text = list_runs(str(root), n)
    if not made:
        assert text.startswith(f"no runs in {root}/")
        return
    shown = made[-n:] if n > 0 else made
    want = [COLUMNS]
    for i, (name, kind, r, seed) in enumerate(made):
        if (name, kind, r, seed) not in shown:
            continue
        if kind == "trace":
            r = {"config": f"/abs/cfg{i}.toml" if i % 2 == 0 else "?", "seed": seed if i % 2 == 0 else "?",
                 "outcome": "(no result)"}
        elif kind == "broken" or not r:  # an empty result.json, and no trace to fall back on
            r = {"outcome": "(unreadable)"}
        sim = r.get("sim_time")
        want.append([name[:8], r.get("started_at", "")[:10] + (" " + r["started_at"][11:19] if "started_at" in r
                                                                else ""),
                     shortened(str(r.get("config", "?"))), str(r.get("seed", "")), r.get("engine") or "?",
                     r.get("outcome", "?"), f"{sim:.2f}" if isinstance(sim, int | float) else "",
                     headline(r.get("result") or {})])
    lines = text.split("\n")
    assert len(lines) == len(want)
    widths = [max(wcswidth(row[c]) for row in want) for c in range(len(COLUMNS) - 1)]
    starts = [sum(w + 2 for w in widths[:c]) for c in range(len(COLUMNS))]
    for line, row in zip(lines, want, strict=True):
        assert line == line.rstrip()
        for c, cell in enumerate(row):
            got = cut(line, starts[c], widths[c] if c < len(widths) else None)
            assert got.rstrip(" ") == cell.rstrip(" "), (c, line)  # the line's end is stripped


def parse_tree(lines: list[str], indent: int = 0) -> tuple[Any, list[str]]:
    """Indented ``key: value`` / ``[i] value`` lines back into dicts and lists (the structure ``tree`` draws)."""
    pad = "  " * indent
    out: Any = None
    while lines and lines[0].startswith(pad) and not lines[0][len(pad):].startswith(" "):
        line = lines.pop(0)[len(pad):]
        if line.startswith("["):
            index, _, rest = line.partition("]")
            out = [] if out is None else out
            assert int(index[1:]) == len(out)
            key, value = None, rest[1:] if rest else None
        else:
            key, sep, value = line.partition(": ")
            if not sep:
                key, value = line.rstrip(":"), None
            out = {} if out is None else out
        if value is None:
            item, lines = parse_tree(lines, indent + 1)
            item = {} if item is None else item
        else:
            item = value
        if key is None:
            out.append(item)
        else:
            out[key] = item
    return out, lines


def same(shown: Any, value: Any) -> bool:
    """A parsed-back tree against the value: containers entry by entry, scalars by their text."""
    if isinstance(value, dict):
        return isinstance(shown, dict) and list(shown) == list(value) and all(
            same(shown[k], v) for k, v in value.items())
    if isinstance(value, list) and isinstance(shown, list):
        return len(shown) == len(value) and all(same(a, b) for a, b in zip(shown, value, strict=True))
    if isinstance(value, str | list):  # strings and short flat lists as JSON
        return json.loads(shown) == value
    return shown == str(value)


nested = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text("kqw_", min_size=1, max_size=3), inner, max_size=4)),
    max_leaves=12)


@PROPS
@given(results, st.dictionaries(st.text("kqw_", min_size=1, max_size=3), nested, max_size=5),
       st.booleans(), st.integers(0, 3))
def test_show_names_every_field_of_the_result_and_its_whole_result_tree(
        tmp_path_factory: pytest.TempPathFactory, result: dict[str, Any], figures: dict[str, Any],
        with_poses: bool, frames: int) -> None:
    folder = tmp_path_factory.mktemp("run") / "0123456789ab"
    folder.mkdir()
    result = {**result, "result": figures}
    (folder / RESULT_FILE).write_text(json.dumps(result, ensure_ascii=False), encoding="utf-8")
    if frames:
        (folder / FRAMES_DIR).mkdir()
        for k in range(frames):
            (folder / FRAMES_DIR / f"cam_{k}_rgb.png").write_bytes(b"png")
    if with_poses:
        np.savez(folder / POSES_FILE, t=np.arange(5) / 30, **{"base/a": np.zeros((5, 7)), "base/b": np.zeros((5, 7)),
                                                             "joints/a": np.zeros((5, 2))})
    lines = show_run(RunRecord(folder)).split("\n")
    assert lines[0] == f"run 0123456789ab   ({folder})"
    keys = [k for k in ("outcome", "reason", "config", "behaviour", "seed", "engine", "started_at", "sim_time",
                        "wall_time", "ticks", "robokit_version") if k in result]
    head = lines[1:1 + len(keys)]
    for line, key in zip(head, keys, strict=True):
        value = f"{result[key]}" + (f" {result['engine_version']}" if key == "engine" and result.get(
            "engine_version") else "")
        assert line == f"  {key}: {value}"
    assert lines[1 + len(keys)] == "  result:"
    rest = lines[2 + len(keys):]
    tail = 2 if with_poses else 1
    body = rest[:-tail]
    assert all(x.startswith("    ") for x in body)
    parsed, left = parse_tree([x[4:] for x in body])
    assert left == []
    assert same({} if parsed is None else parsed, figures)
    files = sorted(p.name for p in folder.iterdir())
    assert rest[-tail] == f"  files: {', '.join(files)}" + (f" ({frames} PNGs in frames/)" if frames else "")
    if with_poses:
        assert rest[-1] == "  pose log: 5 samples, 2 bodies"


@PROPS
@given(nested)
def test_a_tree_reads_back_to_its_value(value: Any) -> None:
    lines = tree({"v": value})
    parsed, left = parse_tree(lines)
    assert left == [] and same(parsed, {"v": value})


@PROPS
@given(st.sampled_from(["result", "end", "poses", "none"]), st.floats(0.1, 50), st.lists(
    st.tuples(st.sampled_from(["arm", "base", "other"]), st.sampled_from(["A", "B", "C"]), st.floats(0, 60)),
    max_size=6), st.booleans(), st.booleans())
def test_a_records_sim_time_and_stays_come_from_its_own_files(
        tmp_path_factory: pytest.TempPathFactory, source: str, end: float,
        moves: list[tuple[str, str, float]], named: bool, readings: bool) -> None:
    """The run's length comes from ``result.json``, else the trace's ``end`` record, else the last pose sample, else
    0; each machine stays in a state from its transition (or t = 0) to the next one or to that length -- "other", a
    machine the header does not name (or every machine of a header without ``machines``), starts in the state its
    first transition leaves, at t = 0; other records between transitions change nothing."""
    folder = tmp_path_factory.mktemp("run")
    header = {**HEADER, "machines": [{"name": "arm", "initial": "A"}, {"name": "base", "initial": "C"}]}
    if not named:
        del header["machines"]
    moves = sorted(moves, key=lambda m: m[2])
    current = {"arm": "A", "base": "C"}
    events: list[dict[str, Any]] = []
    for machine, dest, t in moves:
        src = current.get(machine, "B")
        if readings:
            events.append({"kind": "reading", "t": t, "tick": int(t * 240), "source": "cam", "value": {}})
        events.append({"kind": "transition", "t": t, "tick": int(t * 240), "machine": machine,
                       "source_state": src, "dest_state": dest, "trigger": "go"})
        current[machine] = dest
    if source in ("end", "result"):
        events.append({"kind": "end", "t": end + (1.0 if source == "result" else 0.0), "tick": 0,
                       "outcome": "succeeded", "reason": ""})
    (folder / TRACE_FILE).write_text("\n".join(json.dumps(x) for x in [header, *events]) + "\n", encoding="utf-8")
    if source == "result":
        (folder / RESULT_FILE).write_text(json.dumps({"sim_time": end, "outcome": "succeeded"}), encoding="utf-8")
    if source in ("poses", "result", "end"):
        np.savez(folder / POSES_FILE, t=np.array([0.0, end / 2, end + (2.0 if source != "poses" else 0.0)]))
    rec = RunRecord(folder)
    length = 0.0 if source == "none" else end
    assert rec.sim_time == pytest.approx(length)
    spans = rec.spans()
    assert set(spans) == ({"arm", "base"} if named else set()) | {m for m, _, _ in moves}
    for name, first in (("arm", "A"), ("base", "C"), ("other", "B")):
        mine = [(d, t) for m, d, t in moves if m == name]
        if name not in spans:
            continue
        states = [first, *[d for d, _ in mine]]
        starts = [0.0, *[t for _, t in mine]]
        ends = [*[t for _, t in mine], max(length, starts[-1])]
        assert [(s.state, s.start, s.end) for s in spans[name]] == list(zip(states, starts, ends, strict=True))
        for state, start, stop in zip(states, starts, ends, strict=True):
            if stop - start > 1e-9 and starts.count(start) == 1:  # a stay of its own: its state from its start on
                assert rec.state_at(spans, (start + stop) / 2)[name] == state
                assert rec.state_at(spans, start)[name] == state


def test_a_folder_without_a_record_is_not_a_run_and_an_ambiguous_prefix_lists_five(tmp_path: Path) -> None:
    """A folder named by its path is a run only with a trace or a result in it; a prefix that matches several runs
    is refused naming the first five (12 characters each, oldest first) and "..." when there are more."""
    from robokit.errors import UserError
    from robokit.record.format import find_run

    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="no run"):
        find_run(str(tmp_path / "empty"), tmp_path)
    for count in (2, 5, 6, 7):
        root = tmp_path / f"runs{count}"
        names = [f"abcdef{k:02d}ghijklmnop" for k in range(count)] + ["zzzz"]
        for age, name in enumerate(names):
            (root / name).mkdir(parents=True)
            (root / name / RESULT_FILE).write_text("{}")
            os.utime(root / name / RESULT_FILE, (1000 + age, 1000 + age))  # made in order: the first is the oldest
        with pytest.raises(UserError) as err:
            find_run("abcdef", root)
        assert str(err.value) == (f"run id prefix 'abcdef' matches {count} runs in {root}/: "
                                  + ", ".join(n[:12] for n in names[:min(count, 5)]) + (" ..." if count > 5 else ""))


def test_the_list_shows_the_newest_twenty_by_default(tmp_path: Path) -> None:
    """``robokit results list`` without ``-n``: the 20 newest runs, oldest first; ``-n 0``: every run."""
    names = [f"run{k:03d}xyz" for k in range(23)]
    for age, name in enumerate(names):
        (tmp_path / name).mkdir()
        (tmp_path / name / RESULT_FILE).write_text(json.dumps({"outcome": "succeeded"}))
        os.utime(tmp_path / name / RESULT_FILE, (1000 + age, 1000 + age))
    assert [x.split()[0] for x in list_runs(str(tmp_path)).splitlines()[1:]] == [n[:8] for n in names[-20:]]
    assert [x.split()[0] for x in list_runs(str(tmp_path), 0).splitlines()[1:]] == [n[:8] for n in names]


def test_frames_note_says_where_the_frames_went_or_why_there_are_none(tmp_path: Path) -> None:
    assert frames_note(None, False) is None
    assert frames_note(None, True) == "frames: none saved (--no-record keeps no run folder for them)"
    assert frames_note(tmp_path, False) is None
    assert frames_note(tmp_path, True) == "frames: none saved (no camera rendered a frame)"
    (tmp_path / FRAMES_DIR).mkdir()
    for k in range(3):
        (tmp_path / FRAMES_DIR / f"cam_{k}_rgb.png").write_bytes(b"png")
    (tmp_path / FRAMES_DIR / "notes.txt").write_text("not a frame")
    assert frames_note(tmp_path, False) == f"frames: 3 PNG(s) in {tmp_path / FRAMES_DIR}/"
    assert run_folders(tmp_path / "absent") == []


folders = st.lists(st.tuples(st.sampled_from(["", "configs", "configs/sweeps", "a/b", "a/b/c", "a/b/c/d", ".venv",
                                              "node_modules/x", ".hidden", "results/inner"]),
                             st.integers(0, 2)), max_size=5, unique_by=lambda f: f[0])


@settings(PROPS, max_examples=15)
@given(folders, st.sampled_from(["", "configs", "a/b"]))
def test_the_list_says_where_it_read_and_every_other_results_folder_of_the_checkout(
        tmp_path_factory: pytest.TempPathFactory, made: list[tuple[str, int]], here: str) -> None:
    """``results list``'s note: the folder it read (when it holds runs), then every other ``results`` folder with
    runs at most three folders below the checkout's root (the ``results`` folder itself the third), outside hidden,
    virtual-environment and package folders and outside other ``results`` folders, with its count and the command
    that lists it, in the order of a walk of the sorted folders."""
    from robokit.record.results import where_note

    root = tmp_path_factory.mktemp("checkout")
    (root / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    for parent, runs in made:
        for k in range(runs):
            run = root / parent / "results" / f"run{k}"
            run.mkdir(parents=True)
            (run / RESULT_FILE).write_text("{}")
    start = root / here
    start.mkdir(parents=True, exist_ok=True)
    cwd = os.getcwd()
    os.chdir(start)
    try:
        note = where_note(None, start).splitlines()
    finally:
        os.chdir(cwd)
    read = start / "results"
    counts = {p: n for p, n in made if n}
    want = [f"(runs in {'results'}/)"] if counts.get(here) else []
    skip = (".venv", "node_modules", ".hidden", "results")
    for parent in sorted(counts, key=lambda p: Path(p).parts):  # a walk: a folder's own, then its sub-folders'
        parts = Path(parent).parts
        if (root / parent / "results") == read or len(parts) > 2 or any(p in skip for p in parts):
            continue
        shown = os.path.relpath(root / parent / "results", start) if (root / parent).is_relative_to(start) \
            else str(root / parent / "results")
        want.append(f"(also {counts[parent]} run(s) in {shown}/: robokit results list --dir {shown})")
    assert note == want


@settings(PROPS, max_examples=15)
@given(st.lists(st.tuples(st.binary(max_size=64), st.sampled_from(["ok", "raise", "oserror", "interrupt"])),
                min_size=1, max_size=6), st.sampled_from(["out.mp4", "deep/er/page.html", "run.rrd"]))
def test_an_output_is_whole_or_absent_after_any_sequence_of_writes(
        tmp_path_factory: pytest.TempPathFactory, writes: list[tuple[bytes, str]], name: str) -> None:
    """docs/records.md "Outputs are whole or absent": the name asked for holds the last write that ended normally
    (or nothing), never part of a later one; no temporary file is left; a failed write is one line naming the file."""
    from robokit.record.atomic import OutputFailed, atomic_output, file_digest, write_bytes

    folder = tmp_path_factory.mktemp("out")
    out = folder / name
    last: bytes | None = None
    for data, how in writes:
        if how == "ok":
            write_bytes(out, data)
            last = data
            continue
        error = {"raise": ValueError("stopped"), "oserror": OSError(28, "No space left on device"),
                 "interrupt": KeyboardInterrupt()}[how]
        with pytest.raises((OutputFailed, ValueError, KeyboardInterrupt)) as err:
            with atomic_output(out) as tmp:
                tmp.write_bytes(data[: len(data) // 2])  # half written, then it fails
                raise error
        if how == "oserror":
            assert str(err.value) == f"{out}: not written: No space left on device"
        else:
            assert err.value is error
    assert (out.read_bytes() if out.exists() else None) == last
    if last is not None:
        assert file_digest(out) == "sha256:" + hashlib.sha256(last).hexdigest()
    assert sorted(p.name for p in out.parent.iterdir()) == ([out.name] if last is not None else [])
