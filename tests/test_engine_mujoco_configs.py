"""Every shipped config either runs on the mujoco engine or is refused before the run, in one line naming the key
and the engine (exit code 2, as every config error)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
pytest.importorskip("mujoco")

from robokit.cli import main  # noqa: E402
from robokit.config import load_config  # noqa: E402
from robokit.core.simulation import Simulation  # noqa: E402
from robokit.engines.interface import World  # noqa: E402
from robokit.errors import ConfigError, UserError  # noqa: E402
from robokit.plugin_api.plugins import load_plugins  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted([*(ROOT / "configs").glob("*.toml"), *(ROOT / "configs" / "gym").glob("*.toml")])
RUNS_ON_MUJOCO = {"drop_test", "contact_stop", "go_to_goal", "kuka_dance", "lesson04_rays", "patrol", "patrol_logged",
                  "patrol_robot", "pid_kuka", "pick_place", "sort_robot", "lesson06_collect", "camera_demo",
                  "urdf_gallery", "drive_teleop", "kuka_teleop", "go_to", "reach", "pick", "push", "pick_place_suction",
                  "husky_go_to_goal", "contact_abort", "reach_policy", "plan_dead_end",
                  "pick_obstacle", "patrol_pickup", "pick_gap"}
"""Configs that run on mujoco today; every other one is refused (the test fails when one changes sides silently)."""


@pytest.fixture(scope="module")
def plugins():  # type: ignore[no-untyped-def]
    return load_plugins()


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_config_runs_or_is_refused_in_one_line(path: Path, plugins) -> None:  # type: ignore[no-untyped-def]
    cfg = load_config(path, plugins, {"world.engine": "mujoco"})
    try:
        World.engine_class("mujoco").check_config(cfg)  # the engine's hook, as Simulation calls it
    except ConfigError as exc:
        text = str(exc)
        assert path.stem not in RUNS_ON_MUJOCO, text
        assert "\n" not in text and "mujoco engine" in text
        assert text.startswith(f"{cfg.source}: {exc.key}: ") and exc.key
        head = exc.key.split(".")[0]
        assert head in ("world", "bodies", "robots", "sensors", "actuators", "behaviour", "monitors", "randomize")
        return
    if path.stem not in RUNS_ON_MUJOCO:  # refused while the scene is built (a URDF MuJoCo cannot read)
        with pytest.raises(ConfigError) as info:
            Simulation(cfg, plugins)
        assert "\n" not in str(info.value) and "MuJoCo" in str(info.value) and info.value.key
        return
    with Simulation(cfg, plugins) as sim:
        assert sim.world.engine == "mujoco"
        sim.step(24)
        assert sim.world.tick == 24


def test_the_cli_refuses_with_exit_code_2_before_anything_runs(capsys, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.chdir(tmp_path)  # a run would keep its folder under ./results
    config = ROOT / "configs" / "sort_kuka.toml"
    code = main(["run", str(config), "--engine", "mujoco"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == [f"robokit: error: {config}: robots.kuka.sdf: not supported on the mujoco engine: SDF files are "
                   "not loaded (URDF and primitives are) (--engine pybullet runs it)"]
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]  # nothing was run, nothing kept



def test_a_gui_without_a_display_is_one_line_before_anything_runs(plugins, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.delenv("DISPLAY", raising=False)
    cfg = load_config(ROOT / "configs" / "drop_test.toml", plugins, {"world.engine": "mujoco"})
    World.engine_class("mujoco").check_config(cfg, gui=True)  # the config is fine: MuJoCo's viewer is the window
    with pytest.raises(UserError) as info:
        Simulation(cfg, plugins, gui=True)
    assert str(info.value) == ("MuJoCo's viewer window cannot open: no display (DISPLAY is not set); run headless, "
                               "or under xvfb-run for a virtual one")


def test_pybullet_accepts_what_mujoco_refuses(plugins) -> None:  # type: ignore[no-untyped-def]
    cfg = load_config(ROOT / "configs" / "sort_kuka.toml", plugins, {"world.engine": "mujoco"})
    with pytest.raises(ConfigError, match="robots.kuka.sdf: not supported on the mujoco engine"):
        World.engine_class("mujoco").check_config(cfg)
    assert World.engine_class("pybullet").check_config(cfg, gui=True) is None  # the default hook: no refusal


HIDE_MUJOCO = """
import sys
class Hidden:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] == "mujoco":
            raise ModuleNotFoundError(f"No module named {name!r} (hidden by the test)", name=name)
        return None
sys.meta_path.insert(0, Hidden())
from robokit.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_without_mujoco_the_engine_says_what_to_install(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", HIDE_MUJOCO, "run", str(ROOT / "configs" / "drop_test.toml"),
                           "--engine", "mujoco"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == ["robokit: error: world.engine = \"mujoco\" needs mujoco, which is not "
                                                "installed: pip install 'robokit[mujoco]'"]


@pytest.mark.slow
def test_a_mujoco_run_is_recorded_and_its_video_rebuilt(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from robokit.record.format import find_run

    monkeypatch.chdir(tmp_path)
    config = ROOT / "configs" / "drop_test.toml"
    assert main(["run", str(config), "--engine", "mujoco", "--quiet", "--set", "behaviour.duration=0.5"]) == 0
    rec = find_run("last")
    final = rec.result["result"]["bodies"]["box"]["final_position"]
    logged = rec.poses["base/box"][-1, :3]  # the final state, a tick after the last reading the behaviour saw
    assert [float(v) for v in logged] == pytest.approx(final, abs=2e-3)  # a box moves < 2 mm in a tick
    assert main(["video", "last", "-o", "run.mp4"]) == 0 and (tmp_path / "run.mp4").stat().st_size > 0


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_validate_on_mujoco_passes_what_runs_and_refuses_the_rest(path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    code = main(["validate", str(path), "--engine", "mujoco"])
    err = capsys.readouterr().err
    assert code == (0 if path.stem in RUNS_ON_MUJOCO else 2), err


def test_validate_on_mujoco_finds_bodies_spawned_inside_each_other(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    (tmp_path / "overlap.toml").write_text(
        '[world]\nengine = "mujoco"\n'
        '[bodies.a]\nshape = "box"\nsize = [0.2, 0.2, 0.2]\nmass = 1\nposition = [0, 0, 0.5]\n'
        '[bodies.b]\nshape = "box"\nsize = [0.2, 0.2, 0.2]\nmass = 1\nposition = [0, 0, 0.45]\n')
    assert main(["validate", str(tmp_path / "overlap.toml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'b' is spawned overlapping 'a'" in err[0] and "by 150 mm" in err[0], err
