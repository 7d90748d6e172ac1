"""The run from config to result (:func:`robokit.runner.run_config`, docs/records.md, docs/cli.md), as a property
over generated small runs: real physics, real files read back.

Whatever the seed (the config's or the one given), the length and the outcome: the run's folder is named by its
``run_id`` inside ``[report.local] dir``; its ``result.json`` is the payload that was reported, byte for byte as
JSON, with the seed that ran; the space held for it is given back; the trace file is one JSON object per line, in
tick order, ending at the result's tick; the exit code is the outcome's. Without ``record`` the folder holds
``result.json`` alone, and without ``report`` no ``result.json`` is written. A config problem found at setup
leaves no empty run folder behind.
"""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.config import load_config
from robokit.errors import UserError
from robokit.plugin_api.plugins import load_plugins
from robokit.runner import RESERVE_FILE, run_config

SCENE = """
[world]
max_time = {max_time}
seed = {seed}

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [0, 0, 0.3]

[sensors.poses]
type = "body_pose"

[behaviour]
type = "record"
duration = {duration}

[report.local]
dir = "{folder}"
"""


@pytest.fixture(scope="module")
def plugins():  # type: ignore[no-untyped-def]
    return load_plugins()


@pytest.mark.slow  # a real run per example (~0.2 s each)
@settings(max_examples=4, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31), given_seed=st.one_of(st.none(), st.integers(0, 99)),
       duration=st.sampled_from([0.02, 0.05]), max_time=st.sampled_from([0.03, 0.1]),
       folder=st.sampled_from(["results", "out/runs"]), record=st.booleans(), report=st.booleans())
def test_a_run_keeps_the_result_it_reports_in_its_own_folder(tmp_path: Path, plugins, seed: int,  # type: ignore[no-untyped-def]
                                                           given_seed: int | None, duration: float, max_time: float,
                                                           folder: str, record: bool, report: bool) -> None:
    work = Path(tempfile.mkdtemp(dir=tmp_path))
    config = work / "c.toml"
    config.write_text(SCENE.format(seed=seed, duration=duration, max_time=max_time, folder=work / folder))
    cfg = load_config(config, plugins)
    trace = io.StringIO()
    out = run_config(cfg, plugins, seed=given_seed, record=record, report=report, trace=trace)
    result = out.result
    assert result.seed == (seed if given_seed is None else given_seed)
    want = "succeeded" if duration < max_time else "aborted"
    assert result.outcome == want, result.reason
    assert out.exit_code == {"succeeded": 0, "aborted": 1}[want]
    runs = list((work / folder).iterdir()) if (work / folder).exists() else []
    assert [r.name for r in runs] == ([result.run_id] if record or report else [])  # --no-record: result.json only
    if runs:
        assert not (runs[0] / RESERVE_FILE).exists()
        assert (runs[0] / "trace.jsonl").exists() == record
        kept = runs[0] / "result.json"
        assert kept.exists() == report
        if report:
            assert json.loads(kept.read_text()) == json.loads(json.dumps(out.payload))
            assert out.payload["seed"] == result.seed and out.payload["run_id"] == result.run_id
    lines = [json.loads(line) for line in trace.getvalue().splitlines()]
    ticks = [r["tick"] for r in lines if "tick" in r]
    assert ticks == sorted(ticks) and ticks[-1] <= result.ticks
    assert (out.deliveries != []) == report


def test_a_config_problem_at_setup_leaves_no_run_folder(tmp_path: Path, plugins) -> None:  # type: ignore[no-untyped-def]
    config = tmp_path / "c.toml"
    config.write_text(SCENE.format(seed=1, duration=0.05, max_time=0.1, folder=tmp_path / "results")
                      + '\n[bodies.box]\nshape = "box"\nsize = [0.1, 0.1, 0.1]\nposition = [0, 0, 0.3]\n')
    cfg = load_config(config, plugins)
    with pytest.raises(UserError):
        run_config(cfg, plugins, on_problem=lambda problem: (_ for _ in ()).throw(problem))
    assert list((tmp_path / "results").iterdir()) == []


@pytest.mark.slow  # loads the plugins again with one more distribution (~1 s)
def test_a_reporter_that_cannot_be_built_delivers_nothing_and_says_why(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from plugin_dists import BROKEN_REPORTER, make_dist

    from robokit.runner import make_reporters

    make_dist(tmp_path / "site", "grumpy-dist", "0.9", BROKEN_REPORTER)
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    plugins = load_plugins()
    config = tmp_path / "c.toml"
    config.write_text('[world]\n[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'
                      "[report]\nkeep_local = false\n[report.grumpy]\n")
    (reporter,) = make_reporters(load_config(config, plugins), plugins)
    delivery = reporter.report({"run_id": "x"})
    assert not delivery.delivered and delivery.stored is None
    assert delivery.message.startswith("reporter 'grumpy' (grumpy-dist 0.9) failed to build: RuntimeError: no "
                                       "credentials (at ")
