"""Every result names the engine that ran it, and that engine's version: ``result.json``, ``--json``,
``robokit results list`` and ``show``, a sweep's table and the run page. The engines give different outcomes for
the same config and seed, so a result that does not say which one ran cannot be compared.

The expected versions come from the installed packages' own metadata, not from robokit.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
from importlib.metadata import version
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
mujoco = pytest.importorskip("mujoco")

from robokit.cli import main  # noqa: E402
from robokit.record.format import RunRecord, run_folders  # noqa: E402
from robokit.record.page import build_page  # noqa: E402
from robokit.record.results import list_runs, show_run  # noqa: E402
from robokit.sweep.summary import summarise, to_markdown  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
VERSIONS = {"pybullet": version("pybullet"), "mujoco": mujoco.__version__}


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, dict]]:  # type: ignore[type-arg]
    """One short recorded run of the drop test per engine, in one results folder: (that folder, engine -> the
    run's ``--json`` output)."""
    folder = tmp_path_factory.mktemp("runs")
    printed = {}
    cwd = os.getcwd()
    os.chdir(folder)  # runs keep their folders under ./results
    try:
        for engine in VERSIONS:
            buffer = io.StringIO()
            with contextlib.redirect_stdout(buffer):
                code = main(["run", str(ROOT / "configs" / "drop_test.toml"), "--engine", engine, "--max-time", "0.05",
                             "--json"])
            assert code in (0, 1)
            printed[engine] = json.loads(buffer.getvalue())
    finally:
        os.chdir(cwd)
    return folder / "results", printed


def test_json_and_result_json_name_the_engine_and_its_version(runs: tuple[Path, dict]) -> None:  # type: ignore[type-arg]
    folder, printed = runs
    for engine, expected in VERSIONS.items():
        assert (printed[engine]["engine"], printed[engine]["engine_version"]) == (engine, expected)
        kept = json.loads((folder / printed[engine]["run_id"] / "result.json").read_text())
        assert (kept["engine"], kept["engine_version"]) == (engine, expected)


def test_results_list_and_show_name_the_engine(runs: tuple[Path, dict]) -> None:  # type: ignore[type-arg]
    folder, printed = runs
    table = list_runs(str(folder)).splitlines()
    header = table[0].split()
    assert "engine" in header
    by_id = {line.split()[0]: line for line in table[1:]}
    for engine in VERSIONS:
        assert f" {engine} " in by_id[printed[engine]["run_id"][:8]]
    for run in run_folders(folder):
        rec = RunRecord(run)
        engine = rec.result["engine"]
        assert f"  engine: {engine} {VERSIONS[engine]}" in show_run(rec).splitlines()


def test_the_run_page_names_the_engine(runs: tuple[Path, dict]) -> None:  # type: ignore[type-arg]
    for run in run_folders(runs[0]):
        rec = RunRecord(run)
        engine = rec.result["engine"]
        assert f"engine {engine} {VERSIONS[engine]}" in build_page(rec, None, [])


def test_a_sweep_table_names_each_cells_engine(runs: tuple[Path, dict]) -> None:  # type: ignore[type-arg]
    printed = runs[1]
    rows = [{"cell": f"world.engine={e}", "overrides": {"world.engine": e}, "seed": 0, "outcome": printed[e]["outcome"],
             "reason": "", "figures": {}, "sim_time": printed[e]["sim_time"], "engine": e,
             "engine_version": printed[e]["engine_version"]} for e in VERSIONS]
    summary = summarise(rows, [r["cell"] for r in rows])
    assert [c["engine"] for c in summary["cells"]] == [f"{e} {v}" for e, v in VERSIONS.items()]
    table = to_markdown(summary).splitlines()
    assert table[0].startswith("| cell | engine |")
    for line, (engine, v) in zip(table[2:4], VERSIONS.items(), strict=True):
        assert line.split(" | ")[1] == f"{engine} {v}"
