"""robokit.testing for behaviours: ScriptedRun (no physics), config timeouts, check_behaviour, robokit lint."""

from __future__ import annotations

import enum
import sys
import textwrap
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import pytest

from robokit import hookimpl
from robokit.cli import main
from robokit.errors import ConfigError
from robokit.fsm import MachineBehaviour, MachineConfig
from robokit.msgs import ArmState, BodyState, GripperCommand, GripperState, MoveTo
from robokit.testing import ConformanceError, ScriptedRun, check_behaviour, lint_paths, lint_source

ROOT = Path(__file__).resolve().parents[1]
CUBE = BodyState((0.5, 0.05, 0.025), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
PICK_PLACE = {"object": "cube", "pose_sensor": "poses", "place_position": [0.45, -0.3, 0.027], "max_attempts": 1}
PARTS = {"arm": (ArmState, "actuator"), "gripper": (GripperState, "actuator"), "poses": dict}


class FakeArm:
    """A tiny model of an arm for scripts: reaches a MoveTo target ``delay`` sim seconds after it was sent."""

    def __init__(self, delay: float = 0.3, reaches: bool = True) -> None:
        self.delay, self.reaches = delay, reaches
        self.sent_at: float | None = None
        self.target = (0.3, 0.0, 0.4)
        self.moves: list[tuple[float, float, float]] = []

    def reading(self, t: float, commands: Mapping[str, Any]) -> ArmState:
        move = commands.get("arm")
        if isinstance(move, MoveTo):
            self.sent_at, self.target = t, move.position
            self.moves.append(move.position)
        done = self.reaches and self.sent_at is not None and t - self.sent_at >= self.delay
        return ArmState(self.target, (1.0, 0.0, 0.0, 0.0), "reached" if done else "moving")


def gripper(commands: Mapping[str, Any], last: GripperState) -> GripperState:
    cmd = commands.get("gripper")
    if isinstance(cmd, GripperCommand):
        closing = cmd.action == "close"
        width = 0.05 if closing else 0.08  # closes on the 5 cm cube
        return GripperState(width, width, cmd.action, True, closing, "cube" if closing else None, 2 if closing else 0)
    return last


def test_pick_place_steps_through_every_state_with_scripted_readings() -> None:
    run = ScriptedRun("pick_place", PICK_PLACE, components=PARTS, bodies=["cube"])
    arm, grip = FakeArm(), GripperState(0.08, 0.08, "open", True, False)

    def script(run: ScriptedRun, commands: Mapping[str, Any]) -> dict[str, Any]:
        nonlocal grip
        grip = gripper(commands, grip)
        place = BodyState((0.45, -0.3, 0.027), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))
        cube = place if run.state == "RETREAT" else CUBE
        return {"arm": arm.reading(run.t, commands), "gripper": grip, "poses": {"cube": cube}}

    outcome = run.run(script, max_time=10.0)
    assert outcome is not None and outcome.status == "succeeded", outcome
    assert run.states == ["APPROACH", "DESCEND", "GRASP", "LIFT", "TRANSPORT", "LOWER", "RELEASE", "RETREAT", "DONE"]
    first = run.commands[0]
    assert first["gripper"] == GripperCommand("open")
    assert first["arm"].position == pytest.approx((0.5, 0.05, 0.025 + 0.07))  # above the cube by approach_height
    assert arm.moves[1] == pytest.approx((0.5, 0.05, 0.025))  # then down to the grasp point
    assert run.result()["attempts"] == 1
    # each state waited for the 0.3 s arm: the clock is sim time, advanced 1/240 s per step
    transitions = [r for r in run.trace if r["kind"] == "transition"]
    assert transitions[2]["t"] - transitions[1]["t"] == pytest.approx(0.3, abs=2 / 240)


def test_config_timeouts_override_the_class_timeouts_in_sim_time() -> None:
    run = ScriptedRun("pick_place", {**PICK_PLACE, "timeouts": {"APPROACH": 0.5}}, components=PARTS,
                      bodies=["cube"])
    arm = FakeArm(reaches=False)
    grip = GripperState(0.08, 0.08, "open", True, False)
    outcome = run.run(lambda r, c: {"arm": arm.reading(r.t, c), "gripper": grip, "poses": {"cube": CUBE}}, 5.0)
    assert outcome is not None and outcome.status == "failed"
    assert "timed out in APPROACH after 0.5 s" in outcome.reason
    assert run.t == pytest.approx(0.5, abs=3 / 240)
    assert run.behaviour.timeouts["APPROACH"] == 0.5 and run.behaviour.timeouts["DESCEND"] == 2.0


class Phase(enum.Enum):
    SEARCH = "search"
    FOUND = "found"
    FAILED = "failed"


class SeekConfig(MachineConfig):
    """``sensor``: a float reading; found when it exceeds ``threshold``."""

    sensor: str = "probe"
    threshold: float = 1.0


class Seek(MachineBehaviour):
    """Waits for a reading above a threshold; fails when SEARCH times out."""

    STATES = Phase
    INITIAL = Phase.SEARCH
    TRANSITIONS: ClassVar[list[dict[str, Any]]] = [{"trigger": "seen", "source": "SEARCH", "dest": "FOUND"}]
    TIMEOUTS: ClassVar[dict[str, float]] = {"SEARCH": 2.0}

    def do_search(self, readings: Mapping[str, Any], t: float) -> None:
        if readings[self.config.sensor] > self.config.threshold:
            self.fire("seen")
            self.finish("succeeded", f"seen at {t:.3f} s")


def test_a_machine_gets_config_timeouts_without_overriding_step() -> None:
    default = ScriptedRun(Seek, {}, schema=SeekConfig, components={"probe": float})
    assert default.run(lambda r, c: {"probe": 0.0}, 10.0).reason == "timed out in state SEARCH after 2 s (sim time)"
    quick = ScriptedRun(Seek, {"timeouts": {"SEARCH": 0.25}, "rate_hz": 20}, schema=SeekConfig,
                        components={"probe": float})
    outcome = quick.run(lambda r, c: {"probe": 0.0}, 10.0)
    assert outcome.reason == "timed out in state SEARCH after 0.25 s (sim time)"
    assert quick.t == pytest.approx(0.35)  # the first step past 0.25 s at 20 Hz, then the clock moved on
    found = ScriptedRun(Seek, {}, schema=SeekConfig, components={"probe": float})
    assert found.run(lambda r, c: {"probe": 2.0 if r.t >= 1.0 else 0.0}, 10.0).status == "succeeded"
    assert found.states == ["FOUND"]


def test_a_timeout_for_a_state_the_machine_does_not_have_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"timeouts\.SERACH: unknown state 'SERACH' \(did you mean 'SEARCH'\?\)"):
        ScriptedRun(Seek, {"timeouts": {"SERACH": 1.0}}, schema=SeekConfig, components={"probe": float})
    with pytest.raises(ConfigError, match=r"timeouts\.SEARCH: a timeout is sim seconds > 0"):
        ScriptedRun(Seek, {"timeouts": {"SEARCH": 0}}, schema=SeekConfig, components={"probe": float})


def test_validate_refuses_an_unknown_state_in_a_shipped_config(tmp_path: Path) -> None:
    from robokit.testing import edited_config, validate_error

    bad = edited_config(ROOT / "configs" / "pick_place.toml", tmp_path, "max_attempts = 3",
                        "max_attempts = 3\ntimeouts = { LIFT = 1.5, HOVER = 2.0 }")
    assert "behaviour.timeouts: unknown state 'HOVER'" in validate_error(bad)


def test_a_missing_scripted_reading_and_touching_physics_are_clear_errors() -> None:
    run = ScriptedRun(Seek, {}, schema=SeekConfig, components={"probe": float})
    with pytest.raises(KeyError, match="the script gave no reading for 'probe' at t = 0 s"):
        run.step({})
    with pytest.raises(AttributeError, match="scripted world has no physics: .* world.client"):
        _ = run.world.client


def test_pick_place_conforms() -> None:
    report = check_behaviour("pick_place")
    assert report.outcome.startswith("succeeded") and report.transitions == 9
    assert any("wall clock jumping" in line for line in report.checks)


# ------------------------------------------------------------------ behaviours that break the contract
BROKEN = '''
import time
import pybullet  # noqa: F401  (a behaviour that imports physics)

from robokit import hookimpl
from robokit.components import Behaviour
from robokit.config import Schema

CLOCKS = __import__("time")  # hidden from the lint: the dynamic check must catch it
SCENE = {"world": {"max_time": 0.5}, "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]}}}


class Cfg(Schema):
    """No options."""


class Forever(Behaviour):
    """Never ends."""

    example = SCENE

    def step(self, readings, t):
        return None


class WallClock(Behaviour):
    """Succeeds at 0.25 s sim time, unless a wall-clock timeout of 60 s ran out: depends on the machine's speed."""

    example = SCENE

    def setup(self, ctx):
        super().setup(ctx)
        self.start, self.steps = CLOCKS.perf_counter(), 0

    def step(self, readings, t):
        self.steps += 1
        if CLOCKS.perf_counter() - self.start > 60.0:
            self.finish("failed", f"wall-clock timeout after {self.steps} steps")
        elif t >= 0.25:
            self.finish("succeeded", f"after {self.steps} steps")


@hookimpl
def robokit_register_behaviours(register):
    register("forever", Forever, Cfg)
    register("wall_clock", WallClock, Cfg)
'''


@pytest.fixture
def broken_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    (tmp_path / "broken_behaviours.py").write_text(textwrap.dedent(BROKEN))
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib

    module = importlib.import_module("broken_behaviours")
    yield module
    sys.modules.pop("broken_behaviours", None)


def test_check_behaviour_names_each_broken_contract(broken_module: Any) -> None:
    with pytest.raises(ConformanceError, match=r"'forever' .*: imports: importing broken_behaviours imports pybullet"):
        check_behaviour("forever", extra_plugins=[broken_module])
    source = Path(broken_module.__file__).read_text().replace("import pybullet", "pass  #")
    Path(broken_module.__file__).write_text(source)
    with pytest.raises(ConformanceError, match=r"'forever' .*: outcome: no outcome after the example's max_time"):
        check_behaviour("forever", extra_plugins=[broken_module])
    with pytest.raises(ConformanceError, match=r"'wall_clock' .*: determinism: "):
        check_behaviour("wall_clock", extra_plugins=[broken_module])


# ------------------------------------------------------------------ lint
def test_lint_finds_wall_clock_sleep_and_global_random_through_aliases() -> None:
    source = textwrap.dedent('''
        import time as clock
        import random
        import numpy as np
        from datetime import datetime
        from numpy import random as npr
        from time import sleep, monotonic

        def bad():
            a = clock.perf_counter()
            b = monotonic()
            sleep(0.1)
            c = datetime.now()
            d = random.uniform(0, 1)
            e = np.random.normal(0, 1)
            f = npr.seed(3)
            g = np.random.default_rng()
            return a, b, c, d, e, f, g

        def fine(ctx, seed):
            rng = np.random.default_rng(seed)
            local = random.Random(seed)
            clock.sleep(0.01)  # noqa: RK102 - GUI pacing
            return ctx.rng.normal(), rng.uniform(), local.random()
        ''')
    found = [(f.line, f.code) for f in lint_source(source, "p.py")]
    assert found == [(10, "RK101"), (11, "RK101"), (12, "RK102"), (13, "RK101"), (14, "RK103"), (15, "RK103"),
                     (16, "RK103"), (17, "RK104")]
    assert str(lint_source(source, "p.py")[0]) == ("p.py:10:9: RK101 reads the wall clock (time.perf_counter); use "
                                                   "sim time (the step's t, world.time)")


def test_the_built_in_plugins_behaviours_and_examples_pass_the_lint() -> None:
    packages = [ROOT / "examples" / "robokit-example-plugin", ROOT / "examples" / "robokit-example-behaviour"]
    assert lint_paths([ROOT / "plugins", ROOT / "behaviours", *packages]) == []


def test_robokit_lint_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good, bad = tmp_path / "good.py", tmp_path / "bad" / "plugin.py"
    good.write_text("def f(t):\n    return t * 2\n")
    bad.parent.mkdir()
    bad.write_text("import time\n\n\ndef f():\n    time.sleep(1)\n")
    assert main(["lint", str(good)]) == 0
    assert capsys.readouterr().out == f"1 Python file(s) checked ({good}): no wall-clock reads (RK101), sleeps " \
                                      "(RK102), global random generators (RK103) or unseeded generators (RK104)\n"
    assert main(["lint", str(tmp_path)]) == 1
    assert capsys.readouterr().out.strip() == f"{bad}:5:5: RK102 time.sleep blocks on the wall clock; wait by " \
                                              "staying in a state for sim seconds"
    assert main(["lint", str(tmp_path / "missing")]) == 2
    assert capsys.readouterr().err.strip() == f"robokit: error: {tmp_path / 'missing'}: no such file or folder"
    (tmp_path / "empty").mkdir()  # nothing to check is not a clean lint
    assert main(["lint", str(tmp_path / "empty")]) == 2
    assert capsys.readouterr().err.strip() == f"robokit: error: {tmp_path / 'empty'}: no Python (.py) file to check"


def test_hookimpl_is_what_a_test_registers_with() -> None:
    class Plugin:
        @hookimpl
        def robokit_register_behaviours(self, register: Any) -> None:
            register("seek", Seek, SeekConfig)

    run = ScriptedRun("seek", {"threshold": 0.5}, components={"probe": float}, extra_plugins=[Plugin()])
    assert run.run(lambda r, c: {"probe": 1.0}, 1.0).status == "succeeded"
    assert run.t == pytest.approx(1 / 240)
