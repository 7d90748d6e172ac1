"""Author tooling that cannot hang or be fooled, and pick_place's versioned sub-machine API.

- ``check_behaviour`` / ``check_sensor`` give every plugin call a wall-clock budget: a ``step()`` or ``read()``
  that never returns fails within the budget, naming the type and the call (the run is abandoned, not waited for);
- ``check_behaviour`` catches a behaviour that moves a body through the World or pushes it with the physics
  engine from ``step()``; ``check_sensor`` catches a sensor that leaves a joint force-torque sensor on after
  ``close()``;
- ``PickPlace.sub`` (sub-machine API version 1) reports a bad option as the parent's one-line config error (exit 2).
"""

from __future__ import annotations

import importlib
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from robokit.cli import main
from robokit.testing import ConformanceError, check_behaviour, check_sensor

BAD = '''
from robokit import hookimpl
from robokit.components import Behaviour, Sensor
from robokit.config import Schema

SCENE = {"world": {"max_time": 0.5},
         "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                    "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.05]}}}


class Cfg(Schema):
    """No options."""


class Stuck(Behaviour):
    """Its third step never returns (waits in a loop for something that cannot happen within one step)."""

    example = SCENE

    def step(self, readings, t):
        self.n = getattr(self, "n", 0) + 1
        while self.n == 3:
            pass
        if t >= 0.25:
            self.finish("succeeded", "done")


class Teleport(Behaviour):
    """Moves the box itself at its tenth step instead of commanding an actuator."""

    example = SCENE

    def step(self, readings, t):
        self.n = getattr(self, "n", 0) + 1
        if self.n == 10:
            self.ctx.world.set_pose("box", (0.5, 0.0, 0.05))
        if t >= 0.25:
            self.finish("succeeded", "done")


class Pusher(Behaviour):
    """Pushes the box with an external force from step() (no state changes until the physics step)."""

    example = SCENE

    def step(self, readings, t):
        self.ctx.world.apply_force("box", (5.0, 0.0, 0.0))
        if t >= 0.25:
            self.finish("succeeded", "done")


class StuckSensor(Sensor):
    """Its fourth read never returns."""

    reading_type = float
    example = {"config": {}}

    def read(self):
        self.n = getattr(self, "n", 0) + 1
        while self.n == 4:
            pass
        return 0.0


class LeakyWrist(Sensor):
    """A wrist force sensor that switches pybullet's joint force-torque sensor on and never off."""

    reading_type = float
    example = {"config": {},
               "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}}}

    def setup(self, ctx):
        super().setup(ctx)
        self.body = ctx.body("panda")
        self.joint = ctx.joint("panda", "panda_hand_joint").index
        self.world.client.enableJointForceTorqueSensor(self.body, self.joint, 1)

    def read(self):
        return float(self.world.client.getJointState(self.body, self.joint)[2][2])


@hookimpl
def robokit_register_behaviours(register):
    register("stuck", Stuck, Cfg)
    register("teleport", Teleport, Cfg)
    register("pusher", Pusher, Cfg)


@hookimpl
def robokit_register_sensors(register):
    register("stuck_sensor", StuckSensor, Cfg)
    register("leaky_wrist", LeakyWrist, Cfg)
'''


@pytest.fixture
def bad(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    (tmp_path / "bad_plugins.py").write_text(textwrap.dedent(BAD))
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("bad_plugins")
    yield module
    sys.modules.pop("bad_plugins", None)


@pytest.mark.slow  # the slow tier: the default tier keeps its two-minute budget
def test_check_behaviour_on_a_never_returning_step_fails_within_its_budget(bad: Any) -> None:
    budget = 1.0
    start = time.monotonic()
    with pytest.raises(ConformanceError, match=r"behaviour type 'stuck' \(<local>\): budget: step\(\) at tick 2 did "
                                               r"not return within its wall-clock budget of 1 s \(behaviour 'stuck'\)"):
        check_behaviour("stuck", extra_plugins=[bad], budget=budget)
    elapsed = time.monotonic() - start  # measured under load: the checks before the run take a second or two
    assert elapsed < budget + 15.0


def test_check_sensor_on_a_never_returning_read_fails_within_its_budget(bad: Any) -> None:
    with pytest.raises(ConformanceError, match=r"sensor type 'stuck_sensor' \(<local>\): budget: tick \d+ "
                                               r"\(command, update, read\) did not return within its wall-clock "
                                               r"budget of 0.5 s"):
        check_sensor("stuck_sensor", extra_plugins=[bad], budget=0.5)


def test_check_behaviour_catches_a_behaviour_that_moves_a_body_through_the_world(bad: Any) -> None:
    with pytest.raises(ConformanceError, match=r"'teleport' .*: readings in, commands out: step\(\) at tick 9 called "
                                               r"the physics engine's resetBasePositionAndOrientation\(\)"):
        check_behaviour("teleport", extra_plugins=[bad])


def test_check_behaviour_catches_a_behaviour_that_pushes_with_the_physics_engine(bad: Any) -> None:
    with pytest.raises(ConformanceError, match=r"'pusher' .*: readings in, commands out: step\(\) at tick 0 called "
                                               r"the physics engine's applyExternalForce\(\)"):
        check_behaviour("pusher", extra_plugins=[bad])


def test_check_sensor_catches_a_sensor_that_leaves_a_force_torque_sensor_on(bad: Any) -> None:
    with pytest.raises(ConformanceError, match=r"'leaky_wrist' .*: close: after close\(\) the force-torque sensor of "
                                               r"joint\(s\) panda/panda_hand_joint still measures"):
        check_sensor("leaky_wrist", extra_plugins=[bad])


MUJOCO_SCENE = {"world": {"max_time": 2.0, "engine": "mujoco"},
                "bodies": {"floor": {"shape": "box", "size": [2, 2, 0.1], "mass": 0, "position": [0, 0, -0.05]},
                           "box": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.3]}},
                "sensors": {"poses": {"type": "body_pose", "bodies": ["box"]}}}


def test_check_behaviour_works_on_mujoco_and_catches_a_teleport_there(bad: Any) -> None:
    report = check_behaviour("record", {"duration": 0.5}, scene=MUJOCO_SCENE)
    assert any(line.startswith("changes the world only through its commands") for line in report.checks)
    scene = {**MUJOCO_SCENE, "world": {**MUJOCO_SCENE["world"], "max_time": 5.0}}
    with pytest.raises(ConformanceError, match=r"'teleport' .*: readings in, commands out: step\(\) at tick 9 called "
                                               r"World.set_pose\(\)"):
        check_behaviour("teleport", {}, scene=scene, extra_plugins=[bad])


@pytest.mark.slow
def test_the_built_in_force_torque_sensor_and_guard_are_not_flagged() -> None:
    check_sensor("force_torque")
    check_behaviour("pick_place")  # moves the cube only through the arm and gripper


# ------------------------------------------------------------------ pick_place's sub-machine API
PARENT = '''
from robokit import hookimpl
from robokit.components import Behaviour
from robokit_behaviours.pick_place import PickPlace, PickPlaceTask
from robokit.config import Schema


class TowerConfig(Schema):
    """``pick``: options handed to the pick_place sub-machine."""

    pick: dict = {}


class Tower(Behaviour):
    """Stacks with a pick_place sub-machine (API version 1)."""

    def setup(self, ctx):
        super().setup(ctx)
        self.pp = PickPlace.sub(name="pick", parent_ctx=ctx, api=1, key="pick", **self.config.pick)

    def step(self, readings, t):
        self.finish("succeeded", "built")


@hookimpl
def robokit_register_behaviours(register):
    register("tower", Tower, TowerConfig)
'''


def test_a_sub_machine_option_typo_is_the_parents_one_line_config_error(tmp_path: Path, monkeypatch: Any,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "tower_plugin.py").write_text(textwrap.dedent(PARENT))
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("tower_plugin")
    try:
        from robokit.config import read_toml
        from robokit.errors import ConfigError
        from robokit.testing import make_sim

        raw = read_toml(Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml")
        raw["behaviour"] = {"type": "tower", "pick": {"grasp_offest": 0.01}}
        with pytest.raises(ConfigError) as caught:
            make_sim(raw, extra_plugins=[module], base_dir=Path(__file__).resolve().parents[1] / "configs")
        line = str(caught.value)
        assert line.startswith("<dict>: behaviour.pick.grasp_offest: unknown key 'grasp_offest'"), line
        assert "grasp_offset" in line  # the valid keys are listed
        assert "\n" not in line
        raw["behaviour"] = {"type": "tower", "pick": {"speed": -1}}
        with pytest.raises(ConfigError, match=r"behaviour\.pick\.speed: .*greater than 0"):
            make_sim(raw, extra_plugins=[module], base_dir=Path(__file__).resolve().parents[1] / "configs")
    finally:
        sys.modules.pop("tower_plugin", None)


def test_a_sub_machine_api_version_that_does_not_exist_is_refused() -> None:
    from robokit_behaviours.pick_place import PickPlace

    from robokit.checks.scripted import ScriptedRun
    from robokit.errors import ConfigError
    from robokit.msgs import ArmState, GripperState

    assert PickPlace.SUB_API == 1
    run = ScriptedRun("record", {"components": []})
    with pytest.raises(ConfigError, match=r"pick_place sub-machine API version 2 does not exist; this robokit "
                                          r"provides version 1"):
        PickPlace.sub(parent_ctx=run.ctx, api=2)
    components = {"arm": (ArmState, "actuator"), "gripper": (GripperState, "actuator")}
    run = ScriptedRun("record", {"components": []}, components=components)
    machine = PickPlace.sub(parent_ctx=run.ctx, api=1)
    assert machine.is_sub and machine.config.max_attempts == 1


def test_exit_code_2_for_a_sub_machine_option_error_from_the_cli(tmp_path: Path, monkeypatch: Any,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "tower_plugin2.py").write_text(textwrap.dedent(PARENT).replace('"tower"', '"tower2"'))
    dist = tmp_path / "tower2-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: tower2\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[robokit]\ntower2 = tower_plugin2\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    source = (Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml").read_text()
    head = source[: source.index("[behaviour]")]
    config = tmp_path / "tower.toml"
    config.write_text(head.replace('urdf = "table/table.urdf"', 'urdf = "table/table.urdf"') +
                      '[behaviour]\ntype = "tower2"\npick = { grasp_offest = 0.01 }\n')
    monkeypatch.chdir(Path(__file__).resolve().parents[1] / "configs")
    try:
        assert main(["validate", str(config)]) == 2
    finally:
        sys.modules.pop("tower_plugin2", None)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "behaviour.pick.grasp_offest: unknown key 'grasp_offest'" in err[0], err
    assert err[0].endswith("(behaviour type 'tower2' from tower2 1.0)"), err
