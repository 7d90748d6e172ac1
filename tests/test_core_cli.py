"""The command line, the drop-test scene end to end, and determinism across runs and processes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robokit.cli import main
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parent.parent
DROP = ROOT / "configs" / "drop_test.toml"
VOLATILE = ("run_id", "wall_time", "started_at")


def robokit(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def test_help_imports_neither_pybullet_nor_cv2() -> None:
    code = (
        "import sys\nfrom robokit.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in ('pybullet', 'cv2') if m in sys.modules))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stdout.strip().splitlines()[-1] == "[]"
    assert "validate" in proc.stdout and "inspect" in proc.stdout


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("robokit 0.")


def test_inspect_prints_the_joint_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["inspect", "r2d2.urdf"]) == 0
    out = capsys.readouterr().out
    assert "r2d2.urdf: base link 'base_link', 15 joints" in out
    assert "head_swivel" in out and "revolute" in out and "right_front_wheel_joint" in out


def test_inspect_json_and_missing_urdf(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["inspect", "kuka_iiwa/model.urdf", "--json"]) == 0
    table = json.loads(capsys.readouterr().out)
    assert [j["name"] for j in table["joints"]][:2] == ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2"]
    assert main(["inspect", "nothing_here.urdf"]) == 2
    assert "not found" in capsys.readouterr().err


def test_plugins_lists_builtins_with_distribution(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plugins", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["types"]
    by_name = {(r["kind"], r["type"]): r for r in rows}
    assert by_name[("sensor", "body_pose")]["distribution"] == "robokit"
    assert by_name[("behaviour", "drop_test")]["description"]
    assert ("reporter", "local") in by_name


def test_graph_of_a_non_machine_behaviour_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["graph", "drop_test"]) == 2
    assert "not a state machine" in capsys.readouterr().err
    assert main(["graph", "no_such_behaviour"]) == 2


def test_validate_ok(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", str(DROP)]) == 0
    assert "ok (34 bodies" in capsys.readouterr().out


def _run_json(tmp_path: Path, *extra: str) -> dict:
    proc = robokit("run", str(DROP), "--seed", "3", "--json", *extra, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


@pytest.mark.slow
def test_drop_test_is_deterministic_and_keeps_its_result(tmp_path: Path) -> None:
    first, second = _run_json(tmp_path), _run_json(tmp_path, "--trace", str(tmp_path / "trace.jsonl"))
    assert first["schema"] == "robokit.run/1" and first["outcome"] == "succeeded"
    assert first["run_id"] != second["run_id"]
    for key in VOLATILE:
        first.pop(key), second.pop(key)
    assert first == second
    saved = sorted((tmp_path / "results").glob("*/result.json"))
    assert len(saved) == 2  # one file per run, nothing overwritten
    trace = [json.loads(line) for line in (tmp_path / "trace.jsonl").read_text().splitlines()]
    assert trace == [{"tick": 480, "t": 2.0, "source": "events", "kind": "event", "type": "force", "body": "box"}]


def test_higher_restitution_bounces_higher() -> None:
    with make_sim(DROP, seed=3) as sim:
        result = sim.run()
    bodies = result.result["bodies"]
    peaks = [bodies[f"ball_r{i}"]["peak_bounce_height"] for i in range(10)]
    assert all(b > a for a, b in zip(peaks, peaks[1:], strict=False)), peaks
    assert peaks[0] == pytest.approx(0.05, abs=0.002)  # restitution 0: rests at its radius
    assert bodies["box"]["final_position"][0] > 0.2  # the push at t = 2 s moved it


@pytest.mark.slow
def test_two_worlds_in_one_process_match_separate_processes() -> None:
    code = (
        "import json,sys\nfrom robokit.testing import make_sim\n"
        "with make_sim(sys.argv[1], seed=int(sys.argv[2])) as s:\n"
        "    print(json.dumps(s.run().result))"
    )
    separate = [
        json.loads(subprocess.run([sys.executable, "-c", code, str(DROP), seed], capture_output=True, text=True,
                                  timeout=120, check=True).stdout)
        for seed in ("3", "4")
    ]
    a, b = make_sim(DROP, seed=3), make_sim(DROP, seed=4)
    try:
        while a.outcome is None or b.outcome is None:  # interleaved, tick by tick
            for sim in (a, b):
                if sim.outcome is None:
                    sim.step()
        together = [a.behaviour.result(), b.behaviour.result()]
    finally:
        a.close()
        b.close()
    assert json.loads(json.dumps(together)) == separate
    assert separate[0] != separate[1]


def test_behaviour_modules_never_import_pybullet() -> None:
    code = (
        "import importlib, pkgutil, sys\nimport robokit_behaviours as b\n"
        "for m in pkgutil.iter_modules(b.__path__):\n"
        "    importlib.import_module('robokit_behaviours.' + m.name)\n"
        "print('pybullet' in sys.modules)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "False"


def test_json_stdout_stays_clean_despite_pybullet_warnings(tmp_path: Path) -> None:
    # The humanoid URDF makes pybullet print C-level warnings; --json output must still parse.
    proc = robokit("run", str(ROOT / "configs" / "urdf_gallery.toml"), "--json", "--max-time", "0.5", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert result["outcome"] == "succeeded" and result["reason"] == "no behaviour: simulated 0.5 s"
    assert "pybullet printed 8 message(s)" in proc.stderr and "no axis element for Joint" in proc.stderr
