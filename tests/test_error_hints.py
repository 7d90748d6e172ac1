"""Errors and summaries that carry the hint the user needed: ``urdf =`` on an SDF file names the ``sdf =`` key; the
pybullet warning summary says what the warning says (not the C++ file and line it came from); the sort calls a cube
whose colour has no bin just that; its headline never claims more objects sorted than lie in their bins."""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import pybullet_data
import pytest
import tomllib
from pybullet_utils.bullet_client import BulletClient

from robokit.cli import main
from robokit.process.quiet import CapturedOutput, capture_c_stdout
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
SORT = ROOT / "configs" / "sort_robot.toml"


@pytest.mark.parametrize(("key", "path", "wanted"), [
    ("urdf", "kuka_iiwa/kuka_with_gripper2.sdf", "sdf"),
    ("urdf", "mjcf/humanoid.xml", "mjcf"),
    ("sdf", "r2d2.urdf", "urdf"),
])
def test_a_model_file_under_the_wrong_key_names_the_right_one(
        key: str, path: str, wanted: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tmp_path / "arm.toml"
    config.write_text(f'[world]\nmax_time = 0.1\n\n[bodies.kuka]\n{key} = "{path}"\nposition = [0, 0, 0]\n')
    assert main(["validate", str(config)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"robokit: error: {config}: bodies.kuka: ")
    assert f'the key for it is {wanted} = "{path}"' in err[0]


def test_the_right_key_still_loads(tmp_path: Path) -> None:
    config = tmp_path / "arm.toml"
    config.write_text('[world]\nmax_time = 0.1\n\n[bodies.kuka]\nsdf = "kuka_iiwa/kuka_with_gripper2.sdf"\n'
                      "position = [0, 0, 0]\n")
    assert main(["validate", str(config)]) == 0


def test_the_pybullet_warning_summary_says_what_the_warning_says() -> None:
    """The humanoid has eight joints without an axis: pybullet prints a b3Warning header (Bullet's C++ file and
    line) and the text on the next line for each; the summary shows the text."""
    with capture_c_stdout() as captured:
        client = BulletClient()
        client.setAdditionalSearchPath(pybullet_data.getDataPath())
        client.loadURDF("humanoid/humanoid.urdf")
        client.disconnect()
    assert "BulletUrdfImporter.cpp" in captured.text  # what pybullet really prints
    messages = captured.messages()
    assert len(messages) == 8 and all(m.startswith("urdfdom: no axis element for Joint") for m in messages)
    note = captured.summary()
    assert note is not None and ".cpp" not in note and "b3Warning" not in note
    assert "printed 8 message(s)" in note and "(8x): urdfdom: no axis element for Joint" in note
    assert "chest" in note


def test_the_summary_names_the_most_frequent_kind_and_a_tie_goes_to_the_first_seen() -> None:
    """Kinds are messages without their last word; the summary quotes the most frequent one, and of two as frequent
    the one pybullet printed first."""
    often = CapturedOutput("warning: no inertia for link a\nwarning: no mesh b\nwarning: no inertia for link c\n")
    note = often.summary()
    assert note is not None and "3 message(s) of its own (2 kind(s))" in note
    assert note.endswith("most often (2x): warning: no inertia for link ... (a, c)")
    tie = CapturedOutput("warning: no mesh b\nwarning: no inertia for link a\n")
    assert str(tie.summary()).endswith("most often (1x): warning: no mesh b")
    tie_reversed = CapturedOutput("warning: no inertia for link a\nwarning: no mesh b\n")
    assert str(tie_reversed.summary()).endswith("most often (1x): warning: no inertia for link a")
    assert CapturedOutput("argv[0]=\n").summary() is None


def _sort_scene() -> dict[str, Any]:
    return tomllib.loads(SORT.read_text(encoding="utf-8"))


def _run(raw: dict[str, Any], seed: int, then: Any = None) -> Any:
    """Run the scene to its end (goal check included); ``then = (predicate, action)`` acts once on the way."""
    sim = make_sim(raw, seed=seed, base_dir=SORT.parent)
    try:
        if then is not None:
            assert sim.run_until(then[0], 40 * 240)
            then[1](sim)
        return sim.run()
    finally:
        sim.close()


def test_a_cube_whose_colour_has_no_bin_is_reported_as_such() -> None:
    raw = _sort_scene()
    raw["bodies"]["green"] = {**copy.deepcopy(raw["bodies"]["red"]), "count": 1, "rgba": [0.1, 0.8, 0.2, 1]}
    result = _run(raw, seed=5)
    assert result.outcome == "succeeded" and "whose colour has no bin (green)" in result.reason
    assert "unknown colour" not in result.reason


def test_the_headline_counts_what_is_in_the_bins_not_what_was_placed() -> None:
    """A cube is placed in its bin, then carried off the table out of the camera's view: the sort sees nothing left
    and stops; the goal check finds 0 of 1 in its bin, and the headline must not say "sorted 1"."""
    raw = _sort_scene()
    raw["bodies"]["red"]["count"] = 1
    del raw["bodies"]["blue"]
    raw["sensors"]["truth"]["bodies"] = ["red"]

    def placed(sim: Any) -> bool:
        return any(o.outcome == "sorted" for o in sim.behaviour.objects)

    def carry_off(sim: Any) -> None:
        sim.world.set_pose("red", (3.0, 3.0, 0.03))  # on the floor, far from the table

    result = _run(raw, seed=2, then=(placed, carry_off))
    reason = result.reason
    assert result.outcome == "failed" and "1 of 1 object(s) not in their bin" in reason
    assert not re.search(r"\bsorted 1 object", reason), reason
    assert "placed 1 object(s) in their bins in 1 pick(s), 0 still there" in reason
