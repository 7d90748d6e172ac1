"""``robokit sweep`` on the local backend: the grid, resuming, faults, outputs and reporting (real processes)."""

from __future__ import annotations

import io
import json
import os
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import pytest
from report_server import Answer, CourseServer

from robokit.errors import UserError
from robokit.sweep import SweepOptions, SweepRun, SweepSpec, parse_seeds, parse_set, read_trials, run_sweep
from robokit.sweep.spec import load_sweep_file
from robokit.sweep.summary import percentile, summarise, to_markdown, wilson

ROOT = Path(__file__).resolve().parent.parent
PLUGINS = Path(__file__).resolve().parent / "sweep_plugins"
FAULT = PLUGINS / "fault.toml"
PICK = ROOT / "configs" / "pick_place.toml"
STABLE = ("key", "cell", "overrides", "seed", "run_id", "outcome", "reason", "figures", "sim_time", "ticks")


def stable(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """What must not depend on how a sweep was run (drops wall time, worker and the sweep-specific run id)."""
    return [{k: r[k] for k in STABLE if k != "run_id"} for r in rows]


@pytest.fixture
def fault_plugins(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the test-only plugin module importable here and in spawned workers (they inherit sys.path)."""
    monkeypatch.syspath_prepend(str(PLUGINS))


def robokit(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGINS), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env=env)


# ----------------------------------------------------------------------------------------------- the grid
def test_a_2x3_grid_times_4_seeds_is_24_trials_with_keys_from_the_cell_not_the_order() -> None:
    grid, fixed = parse_set(["behaviour.speed=0.8,1.2", "behaviour.slow_speed=0.3,0.45,0.6", "world.max_time=30"])
    spec = SweepSpec(PICK, parse_seeds("0:4"), grid, fixed)
    trials = spec.trials()
    assert len(trials) == 24 and len({t.key for t in trials}) == 24
    assert trials[0].key == "behaviour.slow_speed=0.3,behaviour.speed=0.8/seed=0"
    assert trials[0].overrides == {"world.max_time": 30, "behaviour.slow_speed": 0.3, "behaviour.speed": 0.8}
    swapped = SweepSpec(PICK, range(0, 4), dict(reversed(list(grid.items()))), fixed)
    assert {t.key: (dict(t.overrides), t.seed) for t in swapped.trials()} == \
        {t.key: (dict(t.overrides), t.seed) for t in trials}


def test_set_values_are_read_as_toml_and_commas_inside_brackets_do_not_split() -> None:
    grid, fixed = parse_set(["behaviour.place_position=[0.45,-0.35,0.027],[0.5,-0.3,0.027]", 'report.student="kim"',
                             "world.gui=false"])
    assert grid == {"behaviour.place_position": ([0.45, -0.35, 0.027], [0.5, -0.3, 0.027])}
    assert fixed == {"report.student": "kim", "world.gui": False}


@pytest.mark.parametrize("text", ["5:2", "a:b", "1:2:3", "-1:3"])
def test_bad_seed_ranges_are_one_line_errors(text: str) -> None:
    with pytest.raises(UserError, match="--seeds"):
        parse_seeds(text)


def test_a_sweep_file_gives_the_same_trials_as_the_command_line(tmp_path: Path) -> None:
    sweep = tmp_path / "speed.toml"
    sweep.write_text(f'config = "{PICK}"\nseeds = "0:4"\nmetrics = ["attempts"]\n\n[grid]\n'
                     'behaviour.speed = [0.8, 1.2]\n"behaviour.slow_speed" = [0.3, 0.45, 0.6]\n', encoding="utf-8")
    spec, _ = load_sweep_file(sweep)
    grid, fixed = parse_set(["behaviour.speed=0.8,1.2", "behaviour.slow_speed=0.3,0.45,0.6"])
    assert [t.key for t in spec.trials()] == [t.key for t in SweepSpec(PICK, range(4), grid, fixed).trials()]
    assert spec.metrics == ("attempts",)
    shipped, options = load_sweep_file(ROOT / "configs" / "sweeps" / "pick_place_speed.toml")
    assert shipped.cells() == spec.cells()
    assert len(shipped.trials()) == 120 and options["trial_timeout"] == 300


def test_wilson_interval_and_percentile() -> None:
    lo, hi = wilson(10, 10)
    assert (round(lo, 4), round(hi, 12)) == (0.7225, 1.0)
    lo, hi = wilson(5, 10)
    assert (round(lo, 4), round(hi, 4)) == (0.2366, 0.7634)
    assert wilson(0, 0) == (0.0, 1.0)
    assert percentile(list(range(1, 21)), 95) == 19 and percentile([3.0], 95) == 3.0


# ----------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("option", "expected"), [
    ("behaviour.sped=1,2", "behaviour.sped: unknown key 'sped' (did you mean 'speed'?)"),
    ("behaviour.speed=-1,1", "behaviour.speed: input should be greater than 0, got -1"),
    ("world.seed.x=1,2", "pick_place.toml: world.seed: expected a table to set 'x' in, got 1"),
])
@pytest.mark.slow
def test_a_bad_key_or_value_is_one_line_before_any_trial_runs(tmp_path: Path, option: str, expected: str) -> None:
    out = tmp_path / "out"
    proc = robokit("sweep", str(PICK), "--seeds", "0:2", "--set", option, "--out", str(out))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and expected in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and not out.exists()


# ----------------------------------------------------------------------------------------------- faults
def check_faults(run: SweepRun, out: Path, timeout: float | None) -> None:
    """Seed 1 raised, seed 3 killed its worker (twice: it is retried once), seed 2 hung (when ``timeout`` is given:
    the sweep had a hanging seed); 0, 4 and 5 succeeded."""
    by_seed = {r["seed"]: r for r in run.rows}
    assert [by_seed[s]["outcome"] for s in range(6)] == \
        ["succeeded", "error", "error" if timeout else "succeeded", "error", "succeeded", "succeeded"]
    assert "RuntimeError: fault injected on seed 1" in by_seed[1]["reason"]
    if timeout:
        assert by_seed[2]["reason"].startswith(f"timed out: no result after {timeout:g} s (--trial-timeout)")
    assert "worker died twice" in by_seed[3]["reason"] and "exit code 17" in by_seed[3]["reason"]
    assert [by_seed[s]["figures"]["seed_squared"] for s in (0, 4, 5)] == [0, 16, 25]
    assert len(read_trials(out / "trials.jsonl")) == 6
    cell = run.summary["cells"][0]
    errors = 3 if timeout else 2
    assert (cell["trials"], cell["succeeded"], cell["errors"]) == (6, 6 - errors, errors)


@pytest.mark.slow
def test_a_trial_that_raises_or_kills_its_worker_is_an_error_and_the_others_finish(
        tmp_path: Path, fault_plugins: None) -> None:
    """No --trial-timeout: nothing here depends on how fast the machine is."""
    spec = SweepSpec(FAULT, range(6), fixed={"behaviour.raise_seeds": [1], "behaviour.die_seeds": [3]},
                     plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=2))
    check_faults(run, tmp_path / "out", None)


@pytest.mark.slow  # waits out real timeouts (tests/test_pins_sweep.py keeps a hanging trial in the default tier)
def test_trials_that_never_end_are_killed_at_the_timeout_and_the_next_runs_on_a_fresh_worker(
        tmp_path: Path, fault_plugins: None) -> None:
    """Every trial here blocks forever, so a timeout however short ends each of them and never a healthy trial
    (there is none to misjudge on a loaded machine): the outcome cannot depend on the machine's speed. One worker:
    the second trial runs only if the pool replaced the worker it killed."""
    spec = SweepSpec(FAULT, range(2), fixed={"behaviour.hang_seeds": [0, 1]}, plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=1, trial_timeout=0.5))
    assert [r["outcome"] for r in run.rows] == ["error", "error"]
    for row in run.rows:
        assert row["reason"].startswith("timed out: no result after 0.5 s (--trial-timeout); worker "), row
        assert row["wall_time"] >= 0.5
    assert run.rows[0]["worker"] != run.rows[1]["worker"]  # the hung worker was killed and replaced


@pytest.mark.slow
def test_a_hung_trial_among_healthy_ones_is_killed_and_the_others_finish(
        tmp_path: Path, fault_plugins: None) -> None:
    """All the faults in one sweep, the hang among healthy trials; the timeout is generous (a healthy trial takes
    well under a second of CPU), so only the trial that never ends reaches it, however loaded the machine."""
    spec = SweepSpec(FAULT, range(6), fixed={"behaviour.raise_seeds": [1], "behaviour.hang_seeds": [2],
                                             "behaviour.die_seeds": [3]}, plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=2, trial_timeout=60.0))
    check_faults(run, tmp_path / "out", 60.0)


def test_a_ray_address_where_nothing_listens_is_one_line_at_once(tmp_path: Path, fault_plugins: None) -> None:
    """Ray itself retries such an address without end (a mistyped port hung the sweep for good)."""
    pytest.importorskip("ray", reason="the Ray backend needs robokit[ray] (in the test extra)")
    with socket.socket() as s:  # a port nothing listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        address = f"127.0.0.1:{s.getsockname()[1]}"
        with pytest.raises(UserError) as caught:
            run_sweep(SweepSpec(FAULT, range(1), plugins=("sweep_faults",)),
                      SweepOptions(out=tmp_path / "out", backend="ray", address=address))
    assert str(caught.value).startswith(f"--address {address}: nothing answers there (Connection refused)")
    assert not (tmp_path / "out" / "trials.jsonl").exists() or not read_trials(tmp_path / "out" / "trials.jsonl")


@pytest.mark.slow  # two whole sweeps: the slow tier
# ----------------------------------------------------------------------------------------------- resuming
def test_stopped_and_resumed_gives_exactly_the_trials_of_one_uninterrupted_sweep(
        tmp_path: Path, fault_plugins: None) -> None:
    grid, fixed = parse_set(["behaviour.duration=0.1,0.15"])
    spec = SweepSpec(FAULT, range(3), grid, fixed, plugins=("sweep_faults",))
    whole = run_sweep(spec, SweepOptions(out=tmp_path / "whole", workers=2))
    part = run_sweep(spec, SweepOptions(out=tmp_path / "part", workers=2, max_trials=2))
    assert (part.ran, part.remaining) == (2, 4)
    with open(tmp_path / "part" / "trials.jsonl", "a", encoding="utf-8") as fh:
        fh.write('{"key": "torn line of a trial that was being writ')  # a crash mid-write
    rest = run_sweep(spec, SweepOptions(out=tmp_path / "part", workers=1))
    assert (rest.ran, rest.skipped, rest.remaining) == (4, 2, 0)
    assert stable(rest.rows) == stable(whole.rows)
    lines = (tmp_path / "part" / "trials.jsonl").read_text(encoding="utf-8").splitlines()
    assert len(lines) == 6 and len({json.loads(line)["key"] for line in lines}) == 6
    again = run_sweep(spec, SweepOptions(out=tmp_path / "part"))
    assert (again.ran, again.skipped) == (0, 6)


def test_resuming_into_a_folder_of_another_config_is_refused(tmp_path: Path, fault_plugins: None) -> None:
    spec = SweepSpec(FAULT, range(1), plugins=("sweep_faults",))
    run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=1))
    other = tmp_path / "other.toml"
    other.write_text(FAULT.read_text(encoding="utf-8").replace("max_time = 1.0", "max_time = 2.0"), encoding="utf-8")
    with pytest.raises(UserError, match="cannot resume this sweep: the config file's text changed"):
        run_sweep(SweepSpec(other, range(1), plugins=("sweep_faults",)), SweepOptions(out=tmp_path / "out"))


class StoppedClock:
    """Stands in for the ``time`` module of the progress display: a clock the test moves by hand."""

    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now


def test_the_rate_after_a_resume_leaves_out_the_workers_start_up(monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.sweep import progress

    clock = StoppedClock()
    monkeypatch.setattr(progress, "time", clock)
    out = io.StringIO()
    shown = progress.Progress(total=40, done=20, failed=0, stream=out)  # resumed: 20 left, a line per trial
    clock.now += 9.0  # the workers start (imports, pybullet) before their first trial runs
    for _batch in range(10):  # 2 workers, 2 s a trial: 1 trial/s
        clock.now += 2.0
        for _ in range(2):
            shown.update({"outcome": "succeeded", "wall_time": 2.0})
    lines = out.getvalue().splitlines()
    assert lines[0] == "sweep: 20/40 trials already done, resuming"
    assert lines[1] == "sweep: 21/40 done, 0 not succeeded, ETA ?"  # one trial tells no rate
    assert lines[2] == "sweep: 22/40 done, 0 not succeeded, 1.00 trials/s, ETA 18 s"
    assert lines[-1] == "sweep: 40/40 done, 0 not succeeded, 1.00 trials/s, ETA 0 s"
    rates = [float(line.split(", ")[2].split()[0]) for line in lines[2:]]
    assert min(rates) >= 0.75 and len(rates) == 19


# ----------------------------------------------------------------------------------------------- outputs
@pytest.mark.slow
def test_cli_writes_trials_summary_junit_and_plots(tmp_path: Path) -> None:
    out = tmp_path / "out"
    junit = tmp_path / "junit.xml"
    proc = robokit("sweep", str(FAULT), "--plugin", "sweep_faults", "--seeds", "0:4", "--set",
                   "behaviour.raise_seeds=[2]", "--set", "behaviour.duration=0.1,0.2", "--workers", "2",
                   "--out", str(out), "--junit", str(junit))
    assert proc.returncode == 1, proc.stderr  # one trial per cell raised
    assert "| `behaviour.duration=0.1` | pybullet " in proc.stdout  # the engine, then its version
    assert " | 4 | 75.0 % | 30.1–95.4 % | 1 |" in proc.stdout
    assert "sweep: 8/8 done, 2 not succeeded" in proc.stdout  # not a terminal: plain progress lines
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert [c["cell"] for c in summary["cells"]] == ["behaviour.duration=0.1", "behaviour.duration=0.2"]
    assert summary["cells"][1]["figures"]["seed_squared"] == {"n": 4, "median": 2.5, "p95": 9.0}
    assert (out / "summary.md").read_text(encoding="utf-8").startswith("| cell | engine | trials | success |")
    suite = ET.parse(junit).getroot().find("testsuite")
    assert suite is not None and (suite.get("tests"), suite.get("errors")) == ("8", "2")
    assert (out / "success_rate.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "distribution_seed_squared.png").stat().st_size > 1000


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_paths_from_a_sweep_file_are_printed_and_stored_without_dot_dot(tmp_path: Path) -> None:
    (tmp_path / "lab" / "sweeps").mkdir(parents=True)
    (tmp_path / "lab" / "scene.toml").write_text(FAULT.read_text(encoding="utf-8"), encoding="utf-8")
    (tmp_path / "lab" / "sweeps" / "s.toml").write_text(
        'config = "../scene.toml"\nseeds = "0:2"\nplugins = ["sweep_faults"]\nout = "../../runs/s"\n'
        "[set]\nbehaviour.raise_seeds = [1]\n", encoding="utf-8")
    proc = robokit("sweep", "lab/sweeps/s.toml", "--workers", "1", cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr  # seed 1 raised
    assert f"trials: {Path('runs/s/trials.jsonl')}; summary: {Path('runs/s/summary.md')}" in proc.stdout
    assert "reproduce: `robokit run lab/scene.toml --seed 1" in proc.stdout, proc.stdout
    assert ".." not in proc.stdout
    summary = json.loads((tmp_path / "runs" / "s" / "summary.json").read_text(encoding="utf-8"))
    assert summary["failed_trials"][0]["command"].startswith("robokit run lab/scene.toml --seed 1")


def test_summary_aggregates_only_the_named_metrics() -> None:
    rows = [{"cell": "a", "overrides": {}, "outcome": "succeeded", "figures": {"x": float(i), "y": 1},
             "sim_time": 1.0, "wall_time": 0.1} for i in range(5)]
    summary = summarise(rows, ["a"], ["x"])
    assert summary["metrics"] == ["x"] and set(summary["cells"][0]["figures"]) == {"x", "sim_time", "wall_time"}
    assert summary["cells"][0]["figures"]["x"]["median"] == 2.0


def test_sim_time_is_one_column_whether_a_result_has_it_or_metrics_name_it(
        tmp_path: Path, fault_plugins: None) -> None:
    spec = SweepSpec(FAULT, range(2), metrics=("seed_squared", "sim_time"), plugins=("sweep_faults",))
    run = run_sweep(spec, SweepOptions(out=tmp_path / "out", workers=1))
    head = to_markdown(run.summary).splitlines()[0]
    assert head.count("sim_time") == 1 and head.count("seed_squared") == 1, head
    ran = [float(r["sim_time"]) for r in run.rows]  # the fault trial's own figures have no sim_time
    assert run.summary["cells"][0]["figures"]["sim_time"]["median"] == pytest.approx(sum(ran) / 2)
    rows = [{"cell": "a", "overrides": {}, "outcome": "succeeded", "figures": {"sim_time": 2.0 + i},
             "sim_time": 9.0, "wall_time": 0.1} for i in range(3)]  # pick_place's result has a sim_time figure
    table = to_markdown(summarise(rows, ["a"]))
    assert table.splitlines()[0].count("sim_time") == 1 and "| 3 / 4 |" in table, table


# ----------------------------------------------------------------------------------------------- reporting
@pytest.mark.slow
def test_report_url_posts_every_trial_exactly_once_and_a_resume_posts_nothing_again(
        tmp_path: Path, fault_plugins: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the outbox folder is relative to the working directory
    server = CourseServer().start()
    server.script(Answer(status=503))  # the first POST fails once: urllib3 retries it
    try:
        spec = SweepSpec(FAULT, range(4), fixed={"behaviour.raise_seeds": [3]},
                         plugins=("sweep_faults",))
        opts = SweepOptions(out=tmp_path / "out", workers=2, report_url=server.url, student="kim", project="A")
        run = run_sweep(spec, opts)
        assert sorted(server.stored) == sorted(r["run_id"] for r in run.rows)
        assert set(server.store_count.values()) == {1}
        assert all(r["delivered"] for r in run.rows)
        stored = server.stored[run.rows[3]["run_id"]]
        assert (stored["outcome"], stored["student"], stored["seed"]) == ("error", "kim", 3)
        requests = len(server.requests)
        run_sweep(spec, opts)
        assert len(server.requests) == requests
        assert not (tmp_path / "results").exists()  # trial results live in the sweep folder only
    finally:
        server.stop()
