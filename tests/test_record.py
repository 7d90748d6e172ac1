"""The run record: every ``robokit run`` keeps results/<run_id>/ with result.json, trace.jsonl and poses.npz."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.errors import UserError
from robokit.record.format import RECORD_SCHEMA, find_run, machines_of
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parent.parent
SORT = ROOT / "configs" / "sort_robot.toml"

SCENE = """
[world]
max_time = 1.0
seed = 4

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0, 0, 0.5]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [1, 0, 0]
fixed_base = true

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
[actuators.joints.sine.lbr_iiwa_joint_1]
amplitude = 1.0
frequency_hz = 0.5

[[events]]
at = 0.5
type = "remove"
body = "box"
"""


@pytest.fixture
def scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def test_a_run_keeps_its_record(scene: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(scene), "--quiet"]) == 0
    assert capsys.readouterr().out == ""  # --quiet: nothing but errors
    rec = find_run("last")
    assert sorted(p.name for p in rec.folder.iterdir()) == ["poses.npz", "result.json", "trace.jsonl"]
    assert rec.result["run_id"] == rec.run_id and rec.result["outcome"] == "succeeded"
    header = rec.header
    assert header["schema"] == RECORD_SCHEMA and header["seed"] == 4 and header["config_text"] == SCENE
    assert header["bodies"]["kuka"]["joints"][0] == "lbr_iiwa_joint_1" and header["bodies"]["box"]["joints"] == []
    # events carry named fields; the last record says how the run ended
    event = next(e for e in rec.events if e["kind"] == "event")
    assert event == {"tick": 120, "t": 0.5, "source": "events", "kind": "event", "type": "remove", "body": "box"}
    assert rec.events[-1]["kind"] == "end" and rec.events[-1]["outcome"] == "succeeded"
    poses = rec.poses
    assert np.allclose(np.diff(poses["t"]), 1 / 30)  # 30 Hz of sim time: every 8th tick at 240 Hz
    assert poses["t"][0] == 0.0 and poses["t"][-1] == pytest.approx(1.0)  # the final state is logged too
    assert poses["base/box"].shape == (31, 7) and poses["joints/kuka"].shape == (31, 7)
    assert poses["base/box"][0, 2] == pytest.approx(0.5)  # placed at z = 0.5 ...
    assert poses["base/box"][10, 2] < 0.5  # ... falling ...
    assert np.isnan(poses["base/box"][16:]).all()  # ... and removed at t = 0.5 s
    wave = poses["joints/kuka"][:, 0]
    assert wave.max() - wave.min() > 0.5  # the joint followed its sine wave


def test_pose_log_rate_is_configurable_and_zero_turns_it_off(scene: Path) -> None:
    assert main(["run", str(scene), "--quiet", "--pose-hz", "0"]) == 0
    assert not find_run("last").has_poses
    assert main(["run", str(scene), "--quiet", "--pose-hz", "60"]) == 0
    assert len(find_run("last").poses["t"]) == 61


def test_results_commands(scene: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(scene), "--quiet"]) == 0
    assert main(["run", str(scene), "--quiet", "--seed", "9"]) == 0
    first, second = (d.name for d in sorted(Path("results").iterdir(), key=lambda d: d.stat().st_mtime))
    assert main(["results", "list"]) == 0
    listing = capsys.readouterr().out.splitlines()
    assert listing[0].split()[:2] == ["run", "started"] and len(listing) == 3
    assert listing[2].startswith(second[:8]) and " 9 " in listing[2] and "succeeded" in listing[2]
    assert main(["results", "show", first[:6]]) == 0
    shown = capsys.readouterr().out
    assert shown.startswith(f"run {first}") and "  outcome: succeeded" in shown and "seed: 4" in shown
    assert main(["results", "last"]) == 0
    assert capsys.readouterr().out.startswith(f"run {second}")
    assert main(["results", "show", "zzz"]) == 2
    assert capsys.readouterr().err.startswith("robokit: error: no run 'zzz' in results/")


def test_find_run_refuses_an_ambiguous_prefix(tmp_path: Path) -> None:
    for name in ("abc1", "abc2"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "result.json").write_text(json.dumps({"run_id": name}))
    assert find_run("abc1", tmp_path).run_id == "abc1"
    assert find_run(str(tmp_path / "abc2")).run_id == "abc2"  # a run folder works too
    with pytest.raises(UserError, match="matches 2 runs"):
        find_run("abc", tmp_path)


def test_the_header_holds_every_state_machine_with_states_transitions_and_timeouts() -> None:
    with make_sim(SORT) as sim:
        machines = {m["name"]: m for m in machines_of(sim.behaviour)}
    assert set(machines) == {"behaviour", "pick_place"}  # sort and the pick_place machine it reuses
    sort, pp = machines["behaviour"], machines["pick_place"]
    assert sort["type"] == "Sort" and sort["initial"] == "CLEAR_VIEW" and "PICK_PLACE" in sort["states"]
    assert pp["timeouts"]["GRASP"] > 0 and {"trigger": "begin", "source": "WAIT", "dest": "APPROACH"} in \
        pp["transitions"]
    json.dumps(machines)  # plain JSON
