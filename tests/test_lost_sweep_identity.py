"""Sweep identity and triage: a resumed sweep whose inputs changed (a file the config refers to, a version) is
refused naming what changed; failed trials are listed with their reason and a command that reproduces each, and
their run records are kept (``--keep``)."""

from __future__ import annotations

import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pybullet_data
import pytest

from robokit.errors import UserError
from robokit.sweep import SweepOptions, SweepSpec, run_sweep

ROOT = Path(__file__).resolve().parent.parent
PLUGINS = Path(__file__).resolve().parent / "sweep_plugins"
FAULT = PLUGINS / "fault.toml"


@pytest.fixture
def scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The fault scene with a body from a URDF next to it, whose visual is a mesh file next to it too."""
    monkeypatch.syspath_prepend(str(PLUGINS))
    data = Path(pybullet_data.getDataPath())
    shutil.copy(data / "cube.urdf", tmp_path / "cube.urdf")
    shutil.copy(data / "cube.obj", tmp_path / "cube.obj")
    config = tmp_path / "scene.toml"
    config.write_text(FAULT.read_text(encoding="utf-8") + '\n[bodies.crate]\nurdf = "cube.urdf"\n'
                      'position = [1, 1, 0.5]\nscale = 0.2\n', encoding="utf-8")
    return config


def spec_of(config: Path, seeds: range = range(2)) -> SweepSpec:
    return SweepSpec(config, seeds, plugins=("sweep_faults",))


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_sweep_json_records_the_files_the_config_refers_to_and_the_versions(scene: Path) -> None:
    """... and growing an unchanged sweep is still accepted."""
    run_sweep(spec_of(scene), SweepOptions(out=scene.parent / "out", workers=1))
    meta = json.loads((scene.parent / "out" / "sweep.json").read_text())
    import hashlib

    expected = {name: hashlib.sha256((scene.parent / name).read_bytes()).hexdigest()
                for name in ("cube.obj", "cube.urdf")}
    assert meta["files"] == expected  # plane.urdf comes with pybullet: covered by its version
    from importlib import metadata

    assert meta["versions"]["robokit"] == metadata.version("robokit")
    assert meta["versions"]["pybullet"] == metadata.version("pybullet")
    grown = run_sweep(spec_of(scene, range(3)), SweepOptions(out=scene.parent / "out", workers=1))
    assert (grown.ran, grown.skipped) == (1, 2)


@pytest.mark.parametrize("changed", ["cube.obj", "cube.urdf"])
def test_growing_a_sweep_after_a_referenced_file_changed_is_refused_naming_it(scene: Path, changed: str) -> None:
    out = scene.parent / "out"
    run_sweep(spec_of(scene), SweepOptions(out=out, workers=1))
    with open(scene.parent / changed, "a", encoding="utf-8") as fh:
        fh.write("\n<!-- replaced -->\n" if changed.endswith(".urdf") else "\n# replaced\n")
    with pytest.raises(UserError) as caught:
        run_sweep(spec_of(scene, range(4)), SweepOptions(out=out, workers=1))  # grown from 2 to 4 seeds
    message = str(caught.value)
    assert "\n" not in message
    assert f"cannot resume this sweep: {changed} changed (sha256 " in message and "--new-out" in message
    assert len((out / "trials.jsonl").read_text().splitlines()) == 2  # nothing was mixed in


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_a_changed_robokit_version_is_refused_and_new_out_starts_a_folder_beside(scene: Path) -> None:
    out = scene.parent / "out"
    run_sweep(spec_of(scene), SweepOptions(out=out, workers=1))
    meta = json.loads((out / "sweep.json").read_text())
    meta["versions"]["robokit"] = "0.0.1"  # as if the folder had been made by an older robokit
    (out / "sweep.json").write_text(json.dumps(meta))
    with pytest.raises(UserError, match=r"robokit 0\.0\.1 -> "):
        run_sweep(spec_of(scene), SweepOptions(out=out, workers=1))
    run = run_sweep(spec_of(scene), SweepOptions(out=out, workers=1, new_out=True))
    assert run.out == scene.parent / "out-2" and run.ran == 2
    assert len((scene.parent / "out-2" / "trials.jsonl").read_text().splitlines()) == 2


def robokit(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


@pytest.mark.slow  # six drop_test trials plus two single runs: ~15 s on two loaded cores
def test_failed_trials_are_listed_with_a_command_that_reproduces_each_and_their_records_kept(
        tmp_path: Path) -> None:
    """drop_test with max_time 1 s never finishes its 5 s of recording (aborted); with 10 s it succeeds. The
    listed command, run alone, gives the same outcome and reason; only the failed trials' records are kept."""
    out = tmp_path / "out"
    proc = robokit("sweep", str(ROOT / "configs" / "drop_test.toml"), "--seeds", "0:3", "--set",
                   "world.max_time=1.0,10.0", "--set", "behaviour.duration=5.0", "--workers", "2", "--out",
                   str(out), cwd=tmp_path)
    assert proc.returncode == 1, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    failed = summary["failed_trials"]
    assert [f["key"] for f in failed] == [f"world.max_time=1.0/seed={s}" for s in range(3)]
    for f in failed:
        assert f["outcome"] == "aborted" and f["reason"].startswith("max_time 1 s reached")
        assert f["command"] in proc.stdout and f["reason"] in proc.stdout
        record = Path(f["record"])
        assert sorted(p.name for p in record.iterdir()) == ["poses.npz", "result.json", "trace.jsonl"]
        assert json.loads((record / "result.json").read_text())["reason"] == f["reason"]
    kept = sorted(p.name for p in (out / "runs").iterdir())
    assert kept == sorted(Path(f["record"]).name for f in failed)  # the successes' records were not kept
    argv = shlex.split(failed[1]["command"])
    assert argv[:2] == ["robokit", "run"]
    again = robokit(*argv[1:], "--json", "--no-record", cwd=tmp_path)
    result = json.loads(again.stdout)
    assert (result["outcome"], result["reason"], result["seed"]) == ("aborted", failed[1]["reason"], 1)
    trial = json.loads((Path(failed[1]["record"]) / "result.json").read_text())
    assert result["result"] == trial["result"]  # the same run, figure for figure


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_keep_none_and_all(scene: Path) -> None:
    none = run_sweep(spec_of(scene), SweepOptions(out=scene.parent / "a", workers=1, keep="none"))
    assert not (scene.parent / "a" / "runs").exists() and all("record" not in r for r in none.rows)
    every = run_sweep(spec_of(scene), SweepOptions(out=scene.parent / "b", workers=1, keep="all"))
    assert len(list((scene.parent / "b" / "runs").iterdir())) == 2
    assert all(Path(r["record"], "result.json").is_file() for r in every.rows)


def test_the_reproduce_command_reads_back_the_same_overrides() -> None:
    """Each override survives the round trip: TOML literal -> shell -> ``--set`` parsing."""
    from robokit.sweep.spec import parse_value
    from robokit.sweep.summary import reproduce_command

    overrides: dict[str, Any] = {"behaviour.speed": 0.8, "behaviour.name": "it's \"odd\"", "world.gui": False,
                                 "behaviour.place_position": [0.4, -0.3, 0.03], "behaviour.n": 3}
    argv = shlex.split(reproduce_command("configs/x y.toml", 7, overrides))
    assert argv[:5] == ["robokit", "run", "configs/x y.toml", "--seed", "7"]
    sets = [argv[i + 1] for i, a in enumerate(argv) if a == "--set"]
    back = {s.partition("=")[0]: parse_value(s.partition("=")[2]) for s in sets}
    assert back == overrides
