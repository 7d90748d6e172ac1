"""``[randomize]`` (docs/randomize.md), as properties over generated sections and seeds.

* **What is drawn, in which order, from where**: a generated section's draws equal the ones the test makes itself
  from the documented stream (``SeedSequence(seed, spawn_key=(0x72616E64,))``) in the documented order — per body in
  creation order a mass factor, a friction factor, a restitution, a damping per movable joint, for a primitive a
  colour (hue in degrees, saturation, value, each within +- its bound); then the light (azimuth about +z from +x,
  elevation above the horizon, in degrees); then each ``dropout`` sensor; then each ``params`` entry (``uniform``
  rounded for an integer setting, ``scale`` times the configured value, ``offset`` added to each component,
  ``choice`` one of the list) — and every draw lies in its closed range.
* **Applied to the world**: the masses, frictions, restitutions and colours PyBullet reports for every link after
  ``apply_world`` are the built values times the drawn factors (static bodies stay static), redraw after redraw
  (no compounding); the light every camera uses is the drawn unit vector.
* **Dropout**: a tick drops with the drawn probability (counted over many ticks), a dropped tick returns the previous
  reading, and whether a tick drops does not depend on how often the sensor is read.
"""

from __future__ import annotations

import colorsys
import math
import zlib
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import tomllib
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robokit.config import RandomizeConfig, validate_model
from robokit.core.randomize import Randomizer, generator, tick_uniform
from robokit.core.simulation import Simulation, build

SHARED = [HealthCheck.function_scoped_fixture]  # the examples share one scene: each undoes what it applies
FAST = settings(max_examples=15, deadline=None, derandomize=True, database=None, suppress_health_check=SHARED)

SCENE = """
[world]
seed = 1
max_time = 0.05

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.red]
shape = "box"
size = [0.05, 0.05, 0.05]
mass = 0.2
count = 2
region = "table"
rgba = [0.9, 0.1, 0.1, 1]
lateral_friction = 0.7
restitution = 0.1

[bodies.ball]
shape = "sphere"
radius = 0.03
mass = 0.05
position = [0.5, 0.5, 0.03]
rgba = [0.1, 0.3, 0.8, 0.5]

[regions.table]
low = [-0.3, -0.3]
high = [0.3, 0.3]
z = 0.03
min_spacing = 0.1

[robots.bot]
urdf = "r2d2.urdf"
position = [1.0, 0, 0.5]

[sensors.scan]
type = "lidar"
position = [0, 0, 0.025]
rays = 16
range_noise = 0.01
range_max = 3.0
"""
NOMINAL_RGBA = {"red_0": (0.9, 0.1, 0.1, 1.0), "red_1": (0.9, 0.1, 0.1, 1.0), "ball": (0.1, 0.3, 0.8, 0.5)}
"""The primitives' configured colours (the bot and the plane are URDFs: no colour drawn)."""
CONFIG_NAME = {"plane": "plane", "red_0": "red", "red_1": "red", "ball": "ball", "bot": "bot"}


def stream(seed: int) -> np.random.Generator:
    """The documented stream, built here from numpy alone."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(0x72616E64,))))


def built() -> Iterator[Simulation]:
    sim = build(tomllib.loads(SCENE))
    try:
        yield sim
    finally:
        sim.close()


@pytest.fixture(scope="module")
def scene() -> Iterator[Simulation]:
    """The scene without ``[randomize]``, for the tests that only draw (drawing leaves the world as it is)."""
    yield from built()


@pytest.fixture
def sim() -> Iterator[Simulation]:
    """The scene of its own, for a test that applies draws (each example undoes the previous one's)."""
    yield from built()


def section(raw: dict[str, Any]) -> Any:
    return validate_model(RandomizeConfig, raw, "randomize")


def movable_joints(sim: Simulation, name: str) -> list[str]:
    c, bid = sim.world.client, sim.world.body(name)
    return [c.getJointInfo(bid, j)[1].decode() for j in range(c.getNumJoints(bid))
            if c.getJointInfo(bid, j)[2] in (c.JOINT_REVOLUTE, c.JOINT_PRISMATIC)]


def jittered(rgba: tuple[float, ...], dh_turns: float, ds: float, dv: float) -> list[float]:
    h, s, v = colorsys.rgb_to_hsv(*rgba[:3])
    clamp = lambda x: min(1.0, max(0.0, x))  # noqa: E731
    return [*colorsys.hsv_to_rgb((h + dh_turns) % 1.0, clamp(s + ds), clamp(v + dv)), rgba[3]]


def expected_draws(raw: dict[str, Any], seed: int, sim: Simulation) -> dict[str, Any]:
    """The documented order, drawn here one number at a time."""
    rng = stream(seed)
    u = lambda bounds: None if bounds is None else rng.uniform(bounds[0], bounds[1])  # noqa: E731
    bodies: dict[str, Any] = {}
    for name in ("plane", "ball", "bot", "red_0", "red_1"):  # creation order of the scene
        if raw.get("bodies") and CONFIG_NAME[name] not in raw["bodies"]:
            continue
        entry: dict[str, Any] = {}
        for key in ("mass_scale", "friction_scale", "restitution"):
            value = u(raw.get(key))
            if value is not None:
                entry[key] = value
        if raw.get("joint_damping") is not None:
            entry["joint_damping"] = {j: u(raw["joint_damping"]) for j in movable_joints(sim, name)}
        colour = (raw.get("colour_hue_deg", 0), raw.get("colour_saturation", 0), raw.get("colour_value", 0))
        if any(colour) and name in NOMINAL_RGBA:
            dh, ds, dv = (rng.uniform(-1.0, 1.0) * bound for bound in colour)
            assert abs(dh) <= colour[0] and abs(ds) <= colour[1] and abs(dv) <= colour[2]
            entry["rgba"] = jittered(NOMINAL_RGBA[name], dh / 360.0, ds, dv)
        bodies[name] = entry
    out: dict[str, Any] = {"bodies": bodies}
    if raw.get("light_azimuth_deg") is not None or raw.get("light_elevation_deg") is not None:
        az = math.radians(u(raw.get("light_azimuth_deg") or (0, 0)))
        el = math.radians(u(raw.get("light_elevation_deg") or (90, 90)))
        out["light_direction"] = [math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)]
    out["dropout"] = {k: u(v) for k, v in raw.get("dropout", {}).items()}
    params: dict[str, Any] = {}
    configured = {"rays": 16, "range_noise": 0.01, "position": (0.0, 0.0, 0.025), "range_max": 3.0}
    for key, dist in raw.get("params", {}).items():
        setting = key.rsplit(".", 1)[1]
        kind, value = next(iter(dist.items()))
        if kind == "choice":
            params[key] = value[rng.integers(len(value))]
        elif kind == "uniform":
            drawn = rng.uniform(*value)
            params[key] = round(drawn) if isinstance(configured[setting], int) else drawn
        elif isinstance(configured[setting], tuple):
            factors = rng.uniform(value[0], value[1], len(configured[setting]))
            params[key] = [c * f if kind == "scale" else c + f for c, f in zip(configured[setting], factors,
                                                                              strict=True)]
        else:
            f = rng.uniform(*value)
            params[key] = configured[setting] * f if kind == "scale" else configured[setting] + f
    out["params"] = params
    return out


def ranges(low: float, high: float) -> st.SearchStrategy[list[float]]:
    return st.tuples(st.floats(low, high), st.floats(low, high)).map(sorted)


params_entries = st.dictionaries(
    st.sampled_from(["sensors.scan.rays", "sensors.scan.range_noise", "sensors.scan.position",
                     "sensors.scan.range_max"]),
    st.one_of(st.builds(lambda r: {"scale": r}, ranges(0.5, 1.5)),
              st.builds(lambda r: {"offset": r}, ranges(-0.01, 0.01))),
    max_size=3)
sections = st.fixed_dictionaries({}, optional={
    "bodies": st.lists(st.sampled_from(["plane", "red", "ball", "bot"]), min_size=1, max_size=3, unique=True),
    "mass_scale": ranges(0.1, 3.0), "friction_scale": ranges(0.0, 2.0), "restitution": ranges(0.0, 1.0),
    "joint_damping": ranges(0.0, 0.2),
    "colour_hue_deg": st.floats(0.5, 30), "colour_saturation": st.floats(0.01, 0.5),
    "colour_value": st.floats(0.01, 0.5),
    "light_azimuth_deg": ranges(-360, 360), "light_elevation_deg": ranges(-90, 90),
    "dropout": st.fixed_dictionaries({"scan": ranges(0.0, 1.0)}),
    "params": params_entries,
})


@FAST
@given(raw=sections, seed=st.integers(0, 2**32 - 1))
def test_a_section_draws_the_documented_numbers_in_the_documented_order(scene: Simulation, raw: dict[str, Any],
                                                                       seed: int) -> None:
    spec = section(raw)
    drawn = Randomizer(spec, scene.config).draw(scene.world, scene.body_keys, generator(seed))
    want = expected_draws(raw, seed, scene)
    assert set(drawn["bodies"]) == set(want["bodies"])
    for name, entry in want["bodies"].items():
        assert drawn["bodies"][name].keys() == entry.keys(), name
        for key, value in entry.items():
            assert drawn["bodies"][name][key] == pytest.approx(value, rel=1e-12, abs=1e-12), (name, key)
    assert ("light_direction" in drawn) == ("light_direction" in want)
    if "light_direction" in want:
        assert drawn["light_direction"] == pytest.approx(want["light_direction"], abs=1e-12)
        assert math.isclose(math.hypot(*drawn["light_direction"]), 1.0)
    assert drawn["dropout"] == pytest.approx(want["dropout"])
    assert drawn["params"].keys() == want["params"].keys()
    for key, value in want["params"].items():
        assert drawn["params"][key] == pytest.approx(value, rel=1e-12, abs=1e-12), key
        assert isinstance(drawn["params"][key], list) == isinstance(value, list), key  # a vector stays a list


@FAST
@given(low=st.floats(0.0, 2.0), width=st.sampled_from([0.0, 0.1, 1.0]), seed=st.integers(0, 10**6))
def test_every_draw_lies_in_its_closed_range_and_an_empty_range_fixes_the_number(
        scene: Simulation, low: float, width: float, seed: int) -> None:
    high = low + width
    raw = {"mass_scale": [low, high], "friction_scale": [low, high], "restitution": [min(low, 1.0)] * 2,
           "joint_damping": [low, high], "dropout": {"scan": [min(low, 1.0), min(high, 1.0)]}}
    drawn = Randomizer(section(raw), scene.config).draw(scene.world, scene.body_keys, generator(seed))
    for entry in drawn["bodies"].values():
        for key in ("mass_scale", "friction_scale"):
            assert low <= entry[key] <= high
            if width == 0.0:
                assert entry[key] == low
        assert entry["restitution"] == min(low, 1.0)
        assert all(low <= d <= high for d in entry["joint_damping"].values())
    assert min(low, 1.0) <= drawn["dropout"]["scan"] <= min(high, 1.0)


def test_colour_and_light_bounds_are_degrees_and_are_reached_over_many_draws(scene: Simulation) -> None:
    """Hue moves by up to +-hue_deg degrees (not radians, not a fraction of 180), both ways; the light's elevation
    and azimuth are degrees; over 300 seeds the extremes come within a tenth of the bounds."""
    raw = {"bodies": ["ball"], "colour_hue_deg": 20, "colour_saturation": 0.1, "colour_value": 0.2,
           "light_azimuth_deg": [30, 60], "light_elevation_deg": [10, 40]}
    randomizer = Randomizer(section(raw), scene.config)
    h0, s0, v0 = colorsys.rgb_to_hsv(*NOMINAL_RGBA["ball"][:3])
    hues, sats, vals, azimuths, elevations = [], [], [], [], []
    for seed in range(300):
        drawn = randomizer.draw(scene.world, scene.body_keys, generator(seed))
        rgba = drawn["bodies"]["ball"]["rgba"]
        assert rgba[3] == NOMINAL_RGBA["ball"][3]
        h, s, v = colorsys.rgb_to_hsv(*rgba[:3])
        hues.append(((h - h0 + 0.5) % 1.0 - 0.5) * 360.0)
        sats.append(s - s0)
        vals.append(v - v0)
        x, y, z = drawn["light_direction"]
        azimuths.append(math.degrees(math.atan2(y, x)))
        elevations.append(math.degrees(math.asin(z)))
    for values, bound in ((hues, 20), (sats, 0.1), (vals, 0.2)):
        assert max(values) <= bound + 1e-9 and min(values) >= -bound - 1e-9
        assert max(values) > 0.9 * bound and min(values) < -0.9 * bound
    assert 30 - 1e-9 <= min(azimuths) < 33 and 57 < max(azimuths) <= 60 + 1e-9
    assert 10 - 1e-9 <= min(elevations) < 13 and 37 < max(elevations) <= 40 + 1e-9
    assert abs(np.mean(hues)) < 2.5  # centred on the configured hue


def test_choice_picks_every_value_equally_often_and_uniform_rounds_an_integer_setting(scene: Simulation) -> None:
    raw = {"params": {"sensors.scan.rays": {"choice": [8, 12, 20]},
                      "sensors.scan.range_max": {"choice": [[1.0, 2.0], [3.0, 4.0]]},
                      "sensors.scan.range_noise": {"uniform": [0.0, 0.1]}}}
    randomizer = Randomizer(section(raw), scene.config)
    counts = {8: 0, 12: 0, 20: 0}
    for seed in range(900):
        params = randomizer.draw(scene.world, scene.body_keys, generator(seed))["params"]
        counts[params["sensors.scan.rays"]] += 1
        assert params["sensors.scan.range_max"] in ([1.0, 2.0], [3.0, 4.0])  # a listed tuple comes back a list
        assert 0.0 <= params["sensors.scan.range_noise"] <= 0.1
    assert all(abs(n - 300) < 5 * math.sqrt(900 * (1 / 3) * (2 / 3)) for n in counts.values()), counts
    rounded = Randomizer(section({"params": {"sensors.scan.rays": {"uniform": [4, 40]}}}), scene.config)
    seen = [rounded.draw(scene.world, scene.body_keys, generator(s))["params"]["sensors.scan.rays"] for s in range(200)]
    assert all(type(n) is int and 4 <= n <= 40 for n in seen) and len(set(seen)) > 25
    spec = next(s for s in scene.config.sensors if s.name == "scan")
    params = rounded.params_for(spec)  # the plugin's own schema validates the drawn value again
    assert params.rays == rounded.drawn["params"]["sensors.scan.rays"] and params.range_max == 3.0
    halves = Randomizer(section({"params": {"sensors.scan.rays": {"uniform": [4, 5]}}}), scene.config)
    fives = sum(halves.draw(scene.world, scene.body_keys, generator(s))["params"]["sensors.scan.rays"] == 5
                for s in range(400))
    assert 140 < fives < 260  # rounded to the nearest integer, not truncated


def link_state(sim: Simulation) -> dict[tuple[str, int], tuple[float, float, float]]:
    c, out = sim.world.client, {}
    for name in sim.world.body_names:
        bid = sim.world.body(name)
        for link in range(-1, c.getNumJoints(bid)):
            info = c.getDynamicsInfo(bid, link)
            out[(name, link)] = (info[0], info[1], info[5])
    return out


@pytest.fixture
def nominal(sim: Simulation) -> dict[tuple[str, int], tuple[float, float, float]]:
    """Every link's mass, friction and restitution as built, read before any draw is applied."""
    return link_state(sim)


@settings(max_examples=8, deadline=None, derandomize=True, database=None, suppress_health_check=SHARED)
@given(seeds=st.lists(st.integers(0, 10**6), min_size=1, max_size=3),
       bodies=st.sampled_from([[], ["red"], ["bot", "ball"]]))
def test_applied_draws_are_what_the_engine_reports_redraw_after_redraw(
        sim: Simulation, nominal: dict[tuple[str, int], tuple[float, float, float]], seeds: list[int],
        bodies: list[str]) -> None:
    raw = {"bodies": bodies, "mass_scale": [0.5, 2.0], "friction_scale": [0.2, 1.8], "restitution": [0.0, 0.9],
           "colour_hue_deg": 25, "colour_saturation": 0.3, "colour_value": 0.3,
           "light_azimuth_deg": [0, 360], "light_elevation_deg": [0, 90]}
    c = sim.world.client
    for (name, link), (mass, friction, restitution) in nominal.items():  # undo the previous example's draws
        c.changeDynamics(sim.world.body(name), link, mass=mass, lateralFriction=friction, restitution=restitution)
    for name, rgba in NOMINAL_RGBA.items():
        c.changeVisualShape(sim.world.body(name), -1, rgbaColor=list(rgba))
    randomizer = Randomizer(section(raw), sim.config)
    for seed in seeds:  # a gym env redraws on the same randomizer: factors act on the built values
        drawn = randomizer.draw(sim.world, sim.body_keys, generator(seed))
        randomizer.apply_world(sim.world)
        now = link_state(sim)
        for (name, link), (mass, friction, _) in nominal.items():
            entry = drawn["bodies"].get(name)
            if entry is None:  # not named in `bodies`: left as built
                assert bodies and CONFIG_NAME[name] not in bodies
                continue
            assert now[(name, link)][0] == pytest.approx(mass * entry["mass_scale"], rel=1e-6)
            assert now[(name, link)][1] == pytest.approx(friction * entry["friction_scale"], rel=1e-6)
            assert now[(name, link)][2] == pytest.approx(entry["restitution"], rel=1e-6, abs=1e-7)
            if mass == 0.0:
                assert now[(name, link)][0] == 0.0  # a static body stays static
        for name, rgba in NOMINAL_RGBA.items():
            if name in drawn["bodies"]:
                shown = c.getVisualShapeData(sim.world.body(name))[0][7]
                assert shown == pytest.approx(drawn["bodies"][name]["rgba"], abs=1e-6)
                h, s, v = colorsys.rgb_to_hsv(*shown[:3])
                h0 = colorsys.rgb_to_hsv(*rgba[:3])[0]
                assert abs((h - h0 + 0.5) % 1.0 - 0.5) <= 25 / 360 + 1e-6 and shown[3] == pytest.approx(rgba[3])
        x, y, z = sim.world.render_options["lightDirection"]
        assert math.isclose(x * x + y * y + z * z, 1.0) and z >= -1e-12  # elevation 0-90: never from below
        assert [x, y, z] == pytest.approx(drawn["light_direction"])


class Counter:
    """A sensor whose every fresh reading is a new number."""

    def __init__(self) -> None:
        self.calls = 0

    def read(self) -> int:
        self.calls += 1
        return self.calls


@settings(max_examples=3, deadline=None, derandomize=True, database=None, suppress_health_check=SHARED)
@given(p=st.floats(0.05, 0.95), seed=st.integers(0, 2**40), reads=st.integers(1, 3))
def test_dropout_drops_with_the_drawn_probability_whatever_the_read_rate(scene: Simulation, p: float, seed: int,
                                                                         reads: int) -> None:
    randomizer = Randomizer(section({"dropout": {"scan": [p, p]}}), scene.config)
    randomizer.draw(scene.world, scene.body_keys, generator(seed))
    assert randomizer.drawn["dropout"]["scan"] == p
    stale: dict[int, list[bool]] = {}
    for per_tick in (1, reads):  # the same ticks read once each, then `reads` times each
        clock = SimpleNamespace(tick=0)
        sensor = Counter()
        randomizer.install_dropout("scan", sensor, clock, seed)  # type: ignore[arg-type]
        previous = sensor.read()  # tick 0: the first reading is always fresh
        flags = []
        for tick in range(1, 401):
            clock.tick = tick
            values = [sensor.read() for _ in range(per_tick)]
            flags.append(values[0] == previous)  # stale: the previous reading came back
            previous = values[-1]
        stale[per_tick] = flags
    assert stale[1] == stale[reads]  # a tick drops or not whatever reads it
    n = len(stale[1])
    assert abs(sum(stale[1]) / n - p) < 5 * math.sqrt(p * (1 - p) / n)
    salt = zlib.crc32(b"scan")
    coins = [tick_uniform(seed, salt, t) for t in range(1, 401)]
    assert all(0.0 <= x < 1.0 for x in coins) and coins == [tick_uniform(seed, salt, t) for t in range(1, 401)]


@pytest.mark.parametrize(("setting", "dist"), [("draw", "scale"), ("robot", "offset"), ("link", "scale")])
def test_scale_or_offset_of_a_setting_without_a_number_is_one_line_at_its_key(scene: Simulation, setting: str,
                                                                              dist: str) -> None:
    from robokit.errors import ConfigError

    randomizer = Randomizer(section({"params": {f"sensors.scan.{setting}": {dist: [1.0, 2.0]}}}), scene.config)
    with pytest.raises(ConfigError) as info:
        randomizer.draw(scene.world, scene.body_keys, generator(0))
    assert info.value.key == f"randomize.params.sensors.scan.{setting}" and "\n" not in str(info.value)
    assert info.value.message.startswith(f"{dist} needs a configured number (or list of numbers), and "
                                         f"sensors.scan.{setting} is ")


def test_each_seed_has_its_own_dropout_ticks() -> None:
    """The coin of a tick depends on the whole seed: no two of 70 seeds drop on the same 32 ticks."""
    salt = zlib.crc32(b"scan")
    patterns = {tuple(tick_uniform(seed, salt, t) < 0.5 for t in range(32)) for seed in range(70)}
    assert len(patterns) == 70


@pytest.mark.parametrize("only", ["colour_hue_deg", "colour_saturation", "colour_value"])
def test_any_one_colour_bound_alone_draws_a_colour_moving_only_that_channel(scene: Simulation, only: str) -> None:
    drawn = Randomizer(section({only: 0.2}), scene.config).draw(scene.world, scene.body_keys, generator(3))
    rgba = drawn["bodies"]["ball"]["rgba"]
    moved = [abs(a - b) > 1e-9 for a, b in zip(colorsys.rgb_to_hsv(*rgba[:3]),
                                                colorsys.rgb_to_hsv(*NOMINAL_RGBA["ball"][:3]), strict=True)]
    assert moved == [only == "colour_hue_deg", only == "colour_saturation", only == "colour_value"]
    assert "rgba" not in drawn["bodies"]["bot"]  # a URDF keeps its own colours
