"""Tests of the ``wander`` behaviour with robokit.testing: scripted readings (no physics), check_behaviour, a run.

Run them after installing the package: ``pip install -e examples/robokit-example-behaviour`` then
``pytest examples/robokit-example-behaviour/tests``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from robokit.cli import main
from robokit.errors import ConfigError
from robokit.msgs import DriveState, LaserScan, Twist
from robokit.testing import ScriptedRun, check_behaviour, lint_paths, make_sim

import robokit_example_wander

HERE = Path(__file__).resolve().parents[1]
PARTS = {"scan": LaserScan, "drive": (DriveState, "actuator")}


def scan(ahead: float, left: float = 3.0, right: float = 3.0, rays: int = 36) -> LaserScan:
    """A 360-degree scan: ``ahead`` m within +-30 deg, ``left``/``right`` m elsewhere on each side."""
    inc = 2 * math.pi / rays
    angles = -math.pi + inc * np.arange(rays)
    ranges = np.where(np.abs(angles) <= math.radians(30), ahead, np.where(angles > 0, left, right))
    return LaserScan(angle_min=-math.pi, angle_max=float(angles[-1]), angle_increment=inc, range_min=0.05,
                     range_max=3.0, ranges=ranges.astype(float), points=np.zeros((rays, 3)), origin=(0, 0, 0.1),
                     yaw=0.0, stamp=0.0)


def drive(distance: float) -> DriveState:
    return DriveState(pose=(0.0, 0.0, 0.0), v=0.0, omega=0.0, odometry=(0.0, 0.0, 0.0), distance=distance,
                      wheel_speeds=(0.0, 0.0))


def test_drives_turns_towards_the_freer_side_and_drives_on() -> None:
    run = ScriptedRun("wander", {"clearance": 0.5}, components=PARTS)
    assert run.step({"scan": scan(2.0), "drive": drive(0.0)}) == {"drive": Twist(0.3, 0.0)}
    assert run.step({"scan": scan(0.4, left=0.6, right=2.5), "drive": drive(0.5)}) == {"drive": Twist(0.0, -1.0)}
    assert run.state == "TURN"
    # still within 1.5 x clearance ahead: keep turning the same way
    assert run.step({"scan": scan(0.7), "drive": drive(0.5)}) == {"drive": Twist(0.0, -1.0)}
    assert run.step({"scan": scan(1.0), "drive": drive(0.5)}) == {"drive": Twist(0.3, 0.0)}
    assert run.states == ["TURN", "DRIVE"] and run.behaviour.turns == 1


def test_succeeds_once_the_distance_is_travelled() -> None:
    run = ScriptedRun("wander", {"distance": 1.0}, components=PARTS, rate_hz=60)
    outcome = run.run(lambda r, c: {"scan": scan(3.0), "drive": drive(0.3 * r.t)}, max_time=10.0)
    assert outcome is not None and outcome.status == "succeeded"
    assert run.t == pytest.approx(1 / 0.3 + 1 / 60, abs=1 / 60)  # 1 m at 0.3 m/s, sim time
    assert run.result()["visited"] == ["DRIVE", "DONE"]


def test_the_config_sets_the_turn_timeout_in_sim_time() -> None:
    boxed_in = {"scan": scan(0.2, 0.2, 0.2), "drive": drive(0.0)}
    default = ScriptedRun("wander", {}, components=PARTS)
    assert default.run(lambda r, c: boxed_in, 60.0).reason == "timed out in TURN after 6 s (sim time)"
    quick = ScriptedRun("wander", {"timeouts": {"TURN": 1.5}}, components=PARTS)
    assert quick.run(lambda r, c: boxed_in, 60.0).reason == "timed out in TURN after 1.5 s (sim time)"
    assert quick.t == pytest.approx(1.5, abs=2 / 240)
    assert quick.states == ["TURN", "FAILED"]


def test_a_timeout_for_an_unknown_state_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="timeouts.TRUN: unknown state 'TRUN'"):
        ScriptedRun("wander", {"timeouts": {"TRUN": 1.0}}, components=PARTS)


def test_conforms_to_the_behaviour_contract() -> None:
    report = check_behaviour("wander")
    assert report.origin.startswith("robokit-example-wander")
    assert report.outcome.startswith("succeeded") and report.transitions >= 3  # it met the wall and turned


def test_the_demo_config_wanders_four_metres_without_touching_anything() -> None:
    with make_sim(HERE / "configs" / "wander_demo.toml") as sim:
        touched: set[str] = set()
        while sim.outcome is None and sim.world.time < 40.0:
            sim.step(1)
            touched.update(sim.readings["drive"].contacts)
        assert sim.outcome is not None and sim.outcome.status == "succeeded", sim.outcome
        assert sim.behaviour.turns >= 1 and sim.behaviour.distance >= 4.0
        assert touched == set()


def test_the_cli_runs_the_demo_and_draws_the_machine(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # the local reporter writes results/ here
    assert main(["run", str(HERE / "configs" / "wander_demo.toml"), "--quiet"]) == 0
    assert main(["graph", "wander"]) == 0
    out = capsys.readouterr().out
    assert "DRIVE --> TURN: blocked" in out and "TURN --> DRIVE: clear" in out


def test_the_package_code_passes_robokit_lint() -> None:
    assert lint_paths([Path(robokit_example_wander.__file__).parent]) == []
