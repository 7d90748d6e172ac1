"""``[randomize]``: draws from the run's own child stream, applied to the world and to plugin settings, recorded, and
the same in a run, a sweep trial and an env reset. A config without it runs bit-identically to before."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomllib

from robokit.core.simulation import build
from robokit.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]

SCENE_TOML = """
[world]
seed = 11
max_time = 0.5

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.cube]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.1
region = "table"
count = 3
yaw_deg_range = [-45, 45]
rgba = [0.9, 0.1, 0.1, 1]
lateral_friction = 0.8

[regions.table]
low = [-0.3, -0.3]
high = [0.3, 0.3]
z = 0.2
min_spacing = 0.1

[robots.bot]
urdf = "r2d2.urdf"
position = [0.6, 0, 0.5]

[sensors.scan]
type = "lidar"
position = [0, 0, 0.025]
rays = 32
range_noise = 0.01
range_max = 3.0
"""
SCENE = tomllib.loads(SCENE_TOML)

# Computed with the code before [randomize] existed (commit 69627fb, this machine's pybullet 3.2.7; the robot's
# landing with Bullet's overlapping pairs sorted, as every PyBullet world has them): the scene's scattered cubes,
# their yaws, the robot and the lidar's seeded noise after 0.5 s.
BEFORE = {
    "bot": (0.5999983962939258, -8.361750118855565e-07, 0.47099248666518717),
    "cube_0": (-0.22286003970988325, -0.00043235362632642823, 0.02498827521487942),
    "cube_1": (0.060897171106199625, -0.2827858268111246, 0.024988299185428792),
    "cube_2": (-0.21124572603178746, 0.25692519794235896, 0.024988293244520406),
}
BEFORE_SCAN = (6, 2.7624357695748873)


def scene(**randomize: Any) -> dict[str, Any]:
    raw = tomllib.loads(SCENE_TOML)
    if randomize:
        raw["randomize"] = randomize
    return raw


def run(raw: dict[str, Any], seed: int | None = None) -> tuple[dict[str, Any], Any]:
    sim = build(raw, seed=seed)
    try:
        result = sim.run()
        poses = {n: tuple(sim.world.pose(n)[0]) for n in sim.world.body_names}
        scan = [r for r in sim.readings["scan"].ranges if math.isfinite(r)]
        poses["scan"] = (len(scan), float(sum(scan)))
    finally:
        sim.close()
    return poses, result


def stream(seed: int) -> np.random.Generator:
    """The documented randomisation stream, built here from numpy alone."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(0x72616E64,))))


def test_a_config_without_randomize_runs_bit_identically_to_before() -> None:
    poses, result = run(scene())
    assert {n: poses[n] for n in BEFORE} == BEFORE
    assert poses["scan"] == BEFORE_SCAN
    assert "randomize" not in result.result


def test_identity_draws_leave_the_run_unchanged() -> None:
    """Drawing (factors of exactly 1, a light no camera uses) takes nothing from the run's own generators."""
    poses, result = run(scene(mass_scale=[1, 1], friction_scale=[1, 1], light_azimuth_deg=[0, 90]))
    assert {n: poses[n] for n in BEFORE} == BEFORE and poses["scan"] == BEFORE_SCAN
    assert set(result.result["randomize"]["bodies"]) == {"plane", "cube_0", "cube_1", "cube_2", "bot"}


def test_draws_follow_the_documented_stream_and_are_applied() -> None:
    raw = scene(bodies=["cube"], mass_scale=[0.5, 1.5], friction_scale=[0.2, 2.0], restitution=[0.0, 0.5])
    sim = build(raw, seed=4)
    try:
        drawn = sim.randomizer.drawn["bodies"]  # type: ignore[union-attr]
        rng = stream(4)
        for name in ("cube_0", "cube_1", "cube_2"):  # config order, three draws a body
            mass, friction, bounce = rng.uniform(0.5, 1.5), rng.uniform(0.2, 2.0), rng.uniform(0.0, 0.5)
            assert drawn[name] == {"mass_scale": mass, "friction_scale": friction, "restitution": bounce}
            info = sim.world.client.getDynamicsInfo(sim.world.body(name), -1)
            assert info[0] == pytest.approx(0.1 * mass) and info[1] == pytest.approx(0.8 * friction)
            assert info[5] == pytest.approx(bounce)
        assert set(drawn) == {"cube_0", "cube_1", "cube_2"}
        result = sim.run()
        assert result.result["randomize"]["bodies"] == drawn
        assert sim.trace[0]["source"] == "randomize" and sim.trace[0]["bodies"] == drawn
    finally:
        sim.close()


def test_joint_damping_slows_a_free_joint() -> None:
    """Damping is checked by its effect: a wheel spun at 10 rad/s with its motor off slows down faster."""
    raw = {"world": {"seed": 3}, "robots": {"bot": {"urdf": "r2d2.urdf", "position": [0, 0, 1], "fixed_base": True}}}
    speeds, drawn = [], None
    for randomize in ({}, {"joint_damping": [0.5, 0.6]}):
        sim = build({**raw, "randomize": randomize} if randomize else raw)
        try:
            c, bot = sim.world.client, sim.world.body("bot")
            wheel = sim.world.joint("bot", "right_front_wheel_joint").index
            c.setJointMotorControl2(bot, wheel, c.VELOCITY_CONTROL, force=0.0)
            c.resetJointState(bot, wheel, 0.0, 10.0)
            for _ in range(100):
                sim.scheduler.tick()
            speeds.append(c.getJointState(bot, wheel)[1])
            if randomize:
                drawn = sim.randomizer.drawn["bodies"]["bot"]["joint_damping"]  # type: ignore[union-attr]
        finally:
            sim.close()
    assert drawn is not None and 0.5 <= drawn["right_front_wheel_joint"] <= 0.6
    assert "right_front_wheel_joint" in drawn and len(drawn) > 4  # every movable joint of r2d2
    assert speeds[1] < 0.85 * speeds[0]


def test_plugin_settings_and_dropout() -> None:
    raw = scene(dropout={"scan": [1.0, 1.0]}, params={"sensors.scan.range_noise": {"uniform": [0.02, 0.03]},
                                                      "sensors.scan.rays": {"choice": [8, 12]}})
    sim = build(raw, seed=2)
    try:
        drawn = sim.randomizer.drawn  # type: ignore[union-attr]
        scan = sim.components["scan"]
        assert scan.config.range_noise == drawn["params"]["sensors.scan.range_noise"]
        assert 0.02 <= scan.config.range_noise <= 0.03 and scan.config.rays in (8, 12)
        first = sim.readings["scan"]
        assert len(first.ranges) == scan.config.rays
        sim.scheduler.tick()
        sim.scheduler.tick()
        assert sim.readings["scan"] is first  # dropout 1: the reading is never renewed (noise would change it)
    finally:
        sim.close()
    sim = build(scene(params={"sensors.scan.range_noise": {"uniform": [0.02, 0.03]}}), seed=2)
    try:
        first = sim.readings["scan"]
        sim.scheduler.tick()
        assert sim.readings["scan"] is not first  # without dropout the reading is renewed every tick
    finally:
        sim.close()


def test_colour_jitter_keeps_the_detector_class_and_light_changes_the_frame() -> None:
    from robokit_plugins.colour_detector import DEFAULT_COLOURS

    raw = scene(colour_hue_deg=15, colour_saturation=0.1, colour_value=0.1)
    raw["sensors"] = {"cam": {"type": "camera", "width": 32, "height": 24, "eye": [0, 0, 1.0], "target": [0, 0, 0],
                              "up": [1, 0, 0], "fov": 70}}
    raw["world"]["max_time"] = 0.05
    frames = []
    for seed in range(6):
        sim = build(raw, seed=seed)
        try:
            for name in ("cube_0", "cube_1", "cube_2"):
                rgba = sim.randomizer.drawn["bodies"][name]["rgba"]  # type: ignore[union-attr]
                assert rgba != [0.9, 0.1, 0.1, 1.0] and DEFAULT_COLOURS["red"].contains_rgb(rgba)
                shown = sim.world.client.getVisualShapeData(sim.world.body(name))[0][7]
                assert shown == pytest.approx(rgba)
        finally:
            sim.close()
    for elevation in (90, 5):
        lit = {**raw, "randomize": {"light_elevation_deg": [elevation, elevation]}}
        sim = build(lit, seed=0)
        try:
            assert sim.world.render_options["lightDirection"][2] == pytest.approx(math.sin(math.radians(elevation)))
            frames.append(sim.readings["cam"].rgb.astype(int))
        finally:
            sim.close()
    assert np.abs(frames[0] - frames[1]).sum() > 0


@pytest.mark.parametrize(("randomize", "key", "words"), [
    ({"mass_scale": [2, 1]}, "randomize", "mass_scale [2.0, 1.0]: the first value must be <= the second"),
    ({"restitution": [0, 2]}, "randomize", "values must be <= 1"),
    ({"bodies": ["cub"]}, "randomize.bodies[0]", "unknown body 'cub' (did you mean 'cube'?); valid: bot, cube, plane"),
    ({"dropout": {"lidar": [0, 1]}}, "randomize.dropout.lidar", "unknown sensor 'lidar'; sensors: scan"),
    ({"params": {"sensors.scan.noise": {"scale": [1, 2]}}}, "randomize.params.sensors.scan.noise",
     "unknown setting 'noise' (did you mean 'range_noise'?) of lidar 'scan'"),
    ({"params": {"sensors.scan.rays": {"scale": [1, 2], "uniform": [1, 2]}}}, "randomize.params.sensors.scan.rays",
     "exactly one of"),
    ({"mass_scle": [1, 2]}, "randomize.mass_scle", "did you mean 'mass_scale'"),
])
def test_bad_sections_are_one_line_errors(randomize: dict[str, Any], key: str, words: str) -> None:
    with pytest.raises(ConfigError) as info:
        build(scene(**randomize))
    text = str(info.value)
    assert "\n" not in text and f"{key}:" in text and words in text


def test_a_drawn_value_the_plugin_refuses_names_the_setting() -> None:
    with pytest.raises(ConfigError, match=r"randomize\.params\.sensors\.scan\.range_noise.*greater than or equal"):
        build(scene(params={"sensors.scan.range_noise": {"uniform": [-1.0, -0.5]}}))


def test_same_seed_same_draws_in_a_run_a_sweep_trial_and_an_env() -> None:
    from robokit.gym.env import RobokitEnv
    from robokit.sweep.trial import TrialTask, run_trial

    config = ROOT / "configs" / "gym" / "push.toml"
    randomize = {"bodies": ["cube"], "mass_scale": [0.5, 1.5], "friction_scale": [0.3, 1.7],
                 "light_elevation_deg": [30, 90], "params": {"sensors.cam.eye": {"offset": [-0.02, 0.02]}}}
    text = config.read_text() + "\n[randomize]\n" + "\n".join(
        f"{k} = {v!r}" for k, v in randomize.items() if k != "params") + (
        '\nparams = { "sensors.cam.eye" = { offset = [-0.02, 0.02] } }\n')
    overrides = {f"randomize.{k}": v for k, v in randomize.items()}
    sim = build(config, overrides={**overrides, "world.max_time": 0.01}, seed=5)
    try:
        in_run = sim.run().result["randomize"]
    finally:
        sim.close()
    row = run_trial(TrialTask("base/seed=5", "base", {"world.max_time": 0.01}, 5,
                              "00000000-0000-0000-0000-000000000000", text.replace("'", '"'), str(config),
                              str(config.parent)))
    assert row["outcome"] == "succeeded", row["reason"]
    env = RobokitEnv(config, overrides=overrides)
    try:
        _, info = env.reset(seed=5)
        assert info["randomize"] == in_run == row["result"]["result"]["randomize"]
        cube = env.world.body("cube")
        mass = env.world.client.getDynamicsInfo(cube, -1)[0]
        assert mass == pytest.approx(0.1 * in_run["bodies"]["cube"]["mass_scale"])
        _, again = env.reset()  # the next episode: new draws, applied over the nominal values (no compounding)
        assert again["randomize"]["bodies"] != in_run["bodies"]
        assert env.world.client.getDynamicsInfo(env.world.body("cube"), -1)[0] == pytest.approx(
            0.1 * again["randomize"]["bodies"]["cube"]["mass_scale"])
        _, info = env.reset(seed=5)
        assert info["randomize"] == in_run
    finally:
        env.close()
    rng = stream(5)
    assert in_run["bodies"]["cube"]["mass_scale"] == rng.uniform(0.5, 1.5)


def test_world_draws_apply_over_what_plugins_set() -> None:
    """The gripper sets its fingers' friction (1.2) in setup: the friction factor scales that value."""
    raw = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
           "actuators": {"gripper": {"type": "gripper", "body": "panda"}},
           "randomize": {"friction_scale": [0.5, 0.5]}}
    sim = build(raw)
    try:
        finger = sim.world.link("panda", "panda_leftfinger")
        assert sim.world.client.getDynamicsInfo(sim.world.body("panda"), finger)[1] == pytest.approx(0.6)
    finally:
        sim.close()


def test_the_video_of_a_randomised_run_shows_the_drawn_colours_and_light(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The video is drawn from the record, not from the run's cameras: its rebuilt bodies take the colours and the
    light ``[randomize]`` drew (from the record's ``randomize``/``drawn`` event), not the config's nominal ones."""
    from robokit.cli import main
    from robokit.record.format import find_run
    from robokit.record.scene import View, rebuild
    from robokit.record.video import Renderer

    monkeypatch.chdir(tmp_path)
    text = SCENE_TOML.replace("max_time = 0.5", "max_time = 0.1") + (
        "\n[randomize]\ncolour_hue_deg = 30\ncolour_value = 0.3\nlight_azimuth_deg = [0, 360]\n"
        "light_elevation_deg = [10, 30]\n")
    (tmp_path / "scene.toml").write_text(text)
    assert main(["run", "scene.toml", "--quiet", "--seed", "2"]) == 0
    rec = find_run("last")
    drawn = rec.result["result"]["randomize"]
    with rebuild(rec) as rebuilt:
        for name in ("cube_0", "cube_1", "cube_2"):
            rgba = drawn["bodies"][name]["rgba"]
            assert rgba != [0.9, 0.1, 0.1, 1.0]
            shown = rebuilt.world.client.getVisualShapeData(rebuilt.world.body(name))[0][7]
            assert shown == pytest.approx(rgba)
        assert rebuilt.light_direction == pytest.approx(drawn["light_direction"])
        rebuilt.set_frame(0)
        x, y, _ = rebuilt.world.pose("cube_0")[0]
        renderer = Renderer(rebuilt, View(eye=(x, y, 0.6), target=(x, y, 0.0), up=(1.0, 0.0, 0.0), fov=8), (16, 16))
        centre = renderer.render()[8, 8].astype(float) / 255  # the cube fills the middle of this narrow view
    lit_nominal = np.array([0.9, 0.1, 0.1])
    lit_drawn = np.array(drawn["bodies"]["cube_0"]["rgba"][:3])
    hue = np.argmax(centre)
    assert hue == np.argmax(lit_drawn)  # the drawn colour's dominant channel, shaded by the drawn light
    assert np.abs(centre / centre.max() - lit_drawn / lit_drawn.max()).sum() < \
        np.abs(centre / centre.max() - lit_nominal / lit_nominal.max()).sum()
