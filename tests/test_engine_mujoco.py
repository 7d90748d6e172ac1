"""The mujoco engine: lesson 01's scene built with MjSpec bounces as its restitutions say, reruns are bit-identical,
and every shipped config either runs on mujoco or is refused before the run in one line naming the key."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
pytest.importorskip("mujoco")

from robokit.config import load_config  # noqa: E402
from robokit.core.simulation import spawn_bodies  # noqa: E402
from robokit.engines.mujoco.world import MujocoWorld  # noqa: E402
from robokit.plugin_api.plugins import load_plugins  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DROP = ROOT / "configs" / "drop_test.toml"
HZ = 240


@pytest.fixture(scope="module")
def plugins():  # type: ignore[no-untyped-def]
    return load_plugins()


def drop_world(plugins, seed: int = 3) -> MujocoWorld:  # type: ignore[no-untyped-def]
    cfg = load_config(DROP, plugins, {"world.engine": "mujoco"})
    world = MujocoWorld(time_step=cfg.world.time_step, seed=seed, base_dir=cfg.base_dir)
    spawn_bodies(world, cfg)
    return world


def peaks(world: MujocoWorld, names: list[str], seconds: float) -> dict[str, float]:
    """Highest base z after each body's first impact (its vertical velocity turning from falling to rising)."""
    best: dict[str, float] = {}
    last = dict.fromkeys(names, 0.0)
    for _ in range(round(seconds * HZ)):
        world.step()
        for name in names:
            z, vz = world.pose(name)[0][2], world.velocity(name)[0][2]
            if name not in best:
                if last[name] < -0.05 and vz >= 0.0:
                    best[name] = z
            else:
                best[name] = max(best[name], z)
            last[name] = vz
    return best


def test_restitution_sets_the_bounce_of_lesson_01s_row_of_balls(plugins) -> None:  # type: ignore[no-untyped-def]
    world = drop_world(plugins)
    row = [f"ball_r{i}" for i in range(10)]
    found = peaks(world, row, 2.0)
    radius, drop = 0.05, 1.0
    # the floor's 0.9 times each ball's restitution (PyBullet's rule); a ball rises to e^2 of its fall
    expected = [radius + (drop - radius) * (0.9 * i / 10) ** 2 for i in range(10)]
    heights = [found.get(name, radius) for name in row]
    assert heights == sorted(heights)  # more restitution, higher bounce
    assert heights[0] < radius + 0.005  # restitution 0: no bounce
    for i in range(3, 10):  # the mapping is a spring-damper's: within 0.1 of the speed ratio asked for
        e_found = np.sqrt(max(heights[i] - radius, 0.0) / (drop - radius))
        assert abs(e_found - 0.9 * i / 10) < 0.1, (i, heights[i], expected[i])


def test_bodies_fall_rest_on_the_plane_and_static_bodies_stay(plugins) -> None:  # type: ignore[no-untyped-def]
    world = drop_world(plugins)
    for _ in range(4 * HZ):
        world.step()
    assert world.pose("box")[0][2] == pytest.approx(0.1, abs=0.01)  # a 0.2 m cube resting on z = 0
    assert world.pose("cylinder")[0][2] == pytest.approx(0.1, abs=0.01)
    assert world.pose("plane")[0] == (0.0, 0.0, 0.0)
    assert world.mass("plane") == 0.0 and world.mass("box") == pytest.approx(1.0)


def test_a_pushed_box_slides_along_the_push(plugins) -> None:  # type: ignore[no-untyped-def]
    world = drop_world(plugins)
    for _ in range(2 * HZ):
        world.step()
    x0 = world.pose("box")[0][0]
    for _ in range(12):  # 60 N for 0.05 s: 3 N·s on 1 kg
        world.apply_force("box", [60.0, 0.0, 0.0])
        world.step()
    assert world.velocity("box")[0][0] > 0.5
    for _ in range(HZ):
        world.step()
    assert world.pose("box")[0][0] > x0 + 0.1


def state_bytes(world: MujocoWorld) -> bytes:
    _, data = world.compiled()
    return bytes(np.concatenate([data.qpos, data.qvel]).tobytes())


def test_same_seed_same_run_bit_for_bit(plugins) -> None:  # type: ignore[no-untyped-def]
    runs = []
    for seed in (7, 7, 8):
        world = drop_world(plugins, seed)
        for _ in range(HZ):
            world.step()
        runs.append(state_bytes(world))
    assert runs[0] == runs[1]
    assert runs[0] != runs[2]  # another seed scatters the 20 random balls elsewhere


def test_removing_a_body_keeps_the_others_state(plugins) -> None:  # type: ignore[no-untyped-def]
    world = drop_world(plugins)
    for _ in range(HZ // 2):
        world.step()
    before = world.pose("box"), world.velocity("box")
    world.remove_body("sphere")
    assert not world.has_body("sphere") and "sphere" not in world.body_names
    assert (world.pose("box"), world.velocity("box")) == before
    world.step()


def test_lesson_01_runs_on_mujoco_and_reruns_identically(plugins) -> None:  # type: ignore[no-untyped-def]
    from robokit.core.simulation import Simulation

    results = []
    for _ in range(2):
        cfg = load_config(DROP, plugins, {"world.engine": "mujoco", "behaviour.duration": 1.0})
        with Simulation(cfg, plugins) as sim:
            out = sim.run(max_time=1.5)
        assert out.outcome == "succeeded", out.reason
        results.append(out.result["bodies"])
    assert results[0] == results[1]
    assert results[0]["ball_r9"]["peak_bounce_height"] > results[0]["ball_r2"]["peak_bounce_height"]


CAMERA_SCENE = {
    "world": {"engine": "mujoco", "max_time": 1.0},
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
               "crate": {"shape": "box", "size": [0.4, 0.4, 0.2], "mass": 0, "position": [0, 0, 0.1],
                         "rgba": [0.9, 0.1, 0.1, 1]}},
    "sensors": {"cam": {"type": "camera", "width": 64, "height": 48, "fov": 40.0, "near": 0.1, "far": 5.0,
                        "eye": [0, 0, 2.0], "target": [0, 0, 0], "up": [0, 1, 0]}},
}


def test_a_camera_renders_rgb_metric_depth_and_body_segmentation() -> None:
    from robokit.core.simulation import build

    with build(CAMERA_SCENE) as sim:
        frame = sim.components["cam"].read()
        crate, plane = sim.world.body("crate"), sim.world.body("plane")
    centre, corner = (24, 32), (2, 2)
    assert frame.depth.shape == (48, 64) and frame.rgb.shape == (48, 64, 3)
    assert frame.depth[centre] == pytest.approx(2.0 - 0.2, abs=0.01)  # looking straight down on the crate's top
    assert frame.depth[corner] == pytest.approx(2.0, abs=0.01)  # the floor, along the view axis
    assert frame.segmentation[centre] == crate and frame.segmentation[corner] == plane
    red, green, blue = (int(v) for v in frame.rgb[centre])
    assert red > 2 * green and red > 2 * blue


def test_a_static_body_can_be_moved_and_stays_put(plugins) -> None:  # type: ignore[no-untyped-def]
    world = drop_world(plugins)
    world.step()
    world.set_pose("plane", (0.0, 0.0, -0.5))  # the floor drops half a metre: bodies fall on to it again
    for _ in range(2 * HZ):
        world.step()
    assert world.pose("plane")[0] == (0.0, 0.0, -0.5) and world.mass("plane") == 0.0
    assert world.pose("box")[0][2] == pytest.approx(-0.5 + 0.1, abs=0.01)
