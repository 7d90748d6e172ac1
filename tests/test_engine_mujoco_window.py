"""MuJoCo's own viewer as the GUI window of the mujoco engine, for real on a virtual display (Xvfb).

Windows opened inside this process share one display for the module (``module_display``): GLFW stays connected to
it until it is terminated at the module's end, before the server stops; MuJoCo's viewer cannot start GLFW again in
the same process after that, so no other module opens a viewer in the test process. A whole run (a subprocess) gets
a display of its own."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("mujoco")  # robokit[mujoco]; the test extra installs it

from robokit.engines.interface import World  # noqa: E402

pytestmark = pytest.mark.slow  # a display server and an OpenGL window per test

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module", autouse=True)
def glfw_let_go(module_display: dict[str, str]) -> Iterator[None]:
    """At the module's end GLFW lets go of the display before its server stops (else Xlib ends the process)."""
    yield
    import glfw

    glfw.terminate()


def run(args: list[str], env: dict[str, str], cwd: Path) -> dict:
    proc = subprocess.run([sys.executable, "-m", "robokit.cli", "run", *args, "--json", "--no-record"],
                          capture_output=True, text=True, timeout=300, cwd=cwd, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]  # the viewer's thread is joined: no crash at exit
    return json.loads(proc.stdout)


def test_a_run_in_the_window_is_the_run_without_it(tmp_path: Path, virtual_display: dict[str, str]) -> None:
    config = str(ROOT / "configs" / "pick_place.toml")
    shown = run([config, "--engine", "mujoco", "--gui"], virtual_display, tmp_path)
    headless = {k: v for k, v in virtual_display.items() if k != "DISPLAY"}
    alone = run([config, "--engine", "mujoco"], headless, tmp_path)
    assert shown["outcome"] == alone["outcome"] == "succeeded"
    assert shown["ticks"] == alone["ticks"]
    assert shown["result"] == alone["result"]  # the window only looks: every figure of the run is the same


def test_the_viewer_shows_the_worlds_own_data_and_its_camera_and_closes_its_thread(
        module_display: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DISPLAY", module_display["DISPLAY"])
    before = set(threading.enumerate())
    world = World.create("mujoco", gui=True)
    try:
        world.add_primitive("box", "box", size=(0.1, 0.1, 0.1), position=(0.0, 0.0, 0.5))
        for _ in range(60):
            world.step()
        window = world.window
        assert window is not None and window.is_open()
        model, data = world.compiled()
        assert window.handle.m is model and window.handle.d is data  # what it draws is the world, not a copy
        window.look(1.2, 30.0, -25.0, [0.1, 0.2, 0.3])
        cam = window.handle.cam
        assert (cam.distance, cam.azimuth, cam.elevation) == (1.2, 120.0, -25.0)
        assert list(cam.lookat) == pytest.approx([0.1, 0.2, 0.3])
        world.add_primitive("late", "box", size=(0.1, 0.1, 0.1), position=(0.5, 0.0, 0.5))  # a recompile
        world.step()
        assert window.handle.m is world.compiled()[0] and window.is_open()  # shown again, on the new model
        assert (window.handle.cam.distance, window.handle.cam.azimuth) == (1.2, 120.0)  # the view kept
    finally:
        world.close()
    assert not world.window.is_open()
    assert [t for t in threading.enumerate() if t not in before and t.is_alive()] == []


def test_gym_human_mode_on_mujoco_opens_the_viewer(module_display: dict[str, str],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    gymnasium = pytest.importorskip("gymnasium")
    import robokit.gym  # noqa: F401 - registers the ids

    monkeypatch.setenv("DISPLAY", module_display["DISPLAY"])
    env = gymnasium.make("robokit/Reach-v0", engine="mujoco", render_mode="human")
    try:
        assert "human" in env.metadata["render_modes"]
        env.reset(seed=0)
        for _ in range(5):
            env.step(env.action_space.sample())
        window = env.unwrapped.world.window
        assert window.is_open() and window.handle.d is env.unwrapped.world.compiled()[1]
        assert env.render() is None  # Gymnasium's human mode draws in the window, returns nothing
    finally:
        env.close()
    assert not window.is_open()
