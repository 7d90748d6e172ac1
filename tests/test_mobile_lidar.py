"""lidar: LaserScan fields, ranges against the analytic distance to a wall, own body ignored, config errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robokit.cli import main
from robokit.msgs.mobile import LaserScan
from robokit.testing import PLANE, make_sim

WALL_X = 2.0  # near face of the wall, m
CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def scene(yaw_deg: float = 0.0, **lidar: object) -> dict:
    return {
        "bodies": {"plane": PLANE,
                   "wall": {"shape": "box", "size": [0.1, 8.0, 0.5], "mass": 0, "position": [WALL_X + 0.05, 0, 0.25]}},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06], "rpy_deg": [0, 0, yaw_deg]}},
        "sensors": {"scan": {"type": "lidar", "rate_hz": 10, **lidar}},
    }


@pytest.mark.parametrize("yaw_deg", [0.0, 20.0])
def test_ranges_match_the_analytic_wall_distance_within_1cm(yaw_deg: float) -> None:
    with make_sim(scene(yaw_deg, rays=360, range_max=6.0)) as sim:
        scan: LaserScan = sim.readings["scan"]
    ox = scan.origin[0]
    world_angles = scan.angles + math.radians(yaw_deg)
    facing = np.abs(world_angles) < math.radians(50)
    expected = (WALL_X - ox) / np.cos(world_angles[facing])
    assert np.isfinite(scan.ranges[facing]).all()
    assert np.max(np.abs(scan.ranges[facing] - expected)) < 0.01
    assert np.allclose(scan.points[facing][:, 0], WALL_X, atol=0.01)  # end points are world frame
    back = np.abs(world_angles) > math.radians(100)
    assert np.isinf(scan.ranges[back]).all() and (scan.ranges[back] > 0).all()  # +inf: no return


def test_laserscan_fields_follow_ros_conventions() -> None:
    with make_sim(scene(rays=90, fov_deg=180.0, range_min=0.1, range_max=4.0)) as sim:
        scan = sim.readings["scan"]
    assert scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.angle_max == pytest.approx(math.pi / 2)
    assert scan.angle_increment == pytest.approx(math.pi / 89)
    assert (scan.range_min, scan.range_max) == (0.1, 4.0)
    assert len(scan.ranges) == 90 and scan.points.shape == (90, 3)
    with make_sim(scene(rays=360)) as sim:
        full = sim.readings["scan"]
    assert full.angle_increment == pytest.approx(2 * math.pi / 360)  # no duplicated ray at +-180 degrees
    assert full.angle_max == pytest.approx(math.pi - full.angle_increment)


@pytest.mark.parametrize("map_in_numpy", [False, True])
def test_own_body_is_not_seen_and_one_batch_per_scan(map_in_numpy: bool) -> None:
    # mounted at the chassis centre, inside the robot's own box: every ray starts inside the robot
    cfg = scene(link="base_link", range_min=0.01, range_max=1.5, map_in_numpy=map_in_numpy)
    with make_sim(cfg) as sim:
        calls = []
        client = sim.world.client
        real = client.rayTestBatch

        def counting(*args, **kwargs):
            calls.append(1)
            return real(*args, **kwargs)

        client.rayTestBatch = counting
        scan = sim.readings["scan"]
        sim.step(48)  # 0.2 s at 240 Hz: the 10 Hz sensor is due twice more
        sim.readings["scan"]
    assert np.isinf(scan.ranges).all()  # the wall is 2 m away, beyond 1.5 m; the robot itself is ignored
    # one batch per scan (no mesh boxes here: every ray goes to PyBullet either way)
    assert len(calls) == 2


def test_lidar_on_unknown_link_is_one_line_at_validate(tmp_path, capsys) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(
        '[robots.robot]\nurdf = "robots/diffbot.urdf"\nposition = [0, 0, 0.06]\n'
        '[sensors.scan]\ntype = "lidar"\nrate_hz = 10\nlink = "laser"\n'
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "sensors.scan.link" in err and "unknown link 'laser'" in err and "lidar_link" in err


def test_range_noise_is_seeded_and_of_the_configured_size() -> None:
    scans = []
    for _ in range(2):
        with make_sim(scene(rays=360, range_max=6.0, range_noise=0.01), seed=5) as sim:
            scans.append(sim.readings["scan"])
    a, b = scans
    assert np.array_equal(a.ranges, b.ranges)  # same seed, same noise
    facing = np.abs(a.angles) < math.radians(50)
    error = a.ranges[facing] - (WALL_X - a.origin[0]) / np.cos(a.angles[facing])
    assert 0.007 < np.std(error) < 0.013 and abs(np.mean(error)) < 0.004


@pytest.mark.parametrize("seed", [0, 5, 2**40])
def test_range_noise_is_the_tick_generators(seed: int) -> None:
    """A scan's range noise is drawn from ``ctx.tick_rng()`` at the scan's tick: the same lidar without noise, in
    the same run, gives the ranges the noise was added to."""
    with make_sim(scene(rays=36, range_noise=0.01), seed=seed) as noisy, \
            make_sim(scene(rays=36, range_noise=0.0), seed=seed) as clean:
        lidar = noisy.components["scan"]
        for _ in range(3):
            noisy.step(7)
            clean.step(7)
            a, b = noisy.components["scan"].read(), clean.components["scan"].read()
            inside = (b.ranges > 0.1) & (b.ranges < 4.9)  # (clipped to [range_min, range_max] otherwise; inf: no hit)
            drawn = lidar.ctx.tick_rng().normal(0.0, 0.01, 36)
            assert inside.sum() > 10
            assert np.allclose(a.ranges[inside], b.ranges[inside] + drawn[inside], rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 5, 2**32 - 1, 2**40])
def test_the_tick_generator_is_the_documented_one(seed: int) -> None:
    """``tick_rng`` (a quicker construction where every seed word fits 32 bits) draws what
    ``default_rng([seed, crc32(key), tick])`` draws."""
    import zlib

    with make_sim(scene(rays=36, range_noise=0.01), seed=seed) as sim:
        ctx = sim.components["scan"].ctx
        for tick in (0, 7, 2**31, 2**32 - 1, 2**32):
            documented = np.random.default_rng([seed, zlib.crc32(ctx.key.encode("utf-8")), tick])
            assert np.array_equal(ctx.tick_rng(tick).normal(0.0, 1.0, 20), documented.normal(0.0, 1.0, 20))


DRAW_PROBE = """
import json, sys
from robokit.core.simulation import build

with build(sys.argv[1], gui=True) as sim:
    client = sim.world.client
    counts = {"lines": 0, "lines_while_rendering": 0}
    rendering = [True]
    configure, add_line = client.configureDebugVisualizer, client.addUserDebugLine

    def spy_configure(flag, enable, *args, **kwargs):
        if flag == client.COV_ENABLE_RENDERING:
            rendering[0] = bool(enable)
        return configure(flag, enable, *args, **kwargs)

    def spy_line(*args, **kwargs):
        counts["lines"] += 1
        counts["lines_while_rendering"] += rendering[0]
        return add_line(*args, **kwargs)

    client.configureDebugVisualizer, client.addUserDebugLine = spy_configure, spy_line
    sim.step(240)  # one sim second: the 10 Hz lidar scans at ticks 0, 24, ..., 216
    counts["scans"] = sim.components["scan"].scans
print(json.dumps(counts))
"""


@pytest.mark.slow
@pytest.mark.parametrize("config", ["go_to_goal.toml", "patrol_robot.toml"])  # every ray by PyBullet; map in numpy
def test_gui_draws_rays_with_rendering_paused(tmp_path, config: str, virtual_display: dict[str, str]) -> None:
    """360 debug lines per scan: each line drawn while the GUI renders waits for a rendered frame (1 s of sim took
    minutes). Counted, not timed: every line of every scan is drawn with rendering paused."""
    cmd = [sys.executable, "-c", DRAW_PROBE, str(CONFIGS / config)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path, env=virtual_display)
    assert proc.returncode == 0, proc.stderr[-2000:]
    counts = json.loads(proc.stdout.strip().splitlines()[-1])
    assert counts["scans"] == 10
    assert counts["lines"] == 10 * 360
    assert counts["lines_while_rendering"] == 0


def test_patrol_scans_are_the_same_with_the_map_in_numpy() -> None:
    """The shipped patrol scene, 3 s of its own run: every scan with the static map intersected in numpy equals the
    scan with every ray cast by PyBullet (the numpy path answers most rays itself)."""
    scans: dict[bool, list[LaserScan]] = {}
    for in_numpy in (True, False):
        with make_sim(CONFIGS / "patrol_robot.toml", seed=3,
                      overrides={"sensors.scan.map_in_numpy": in_numpy}) as sim:
            scans[in_numpy] = []
            for _ in range(30):
                scans[in_numpy].append(sim.readings["scan"])
                sim.step(24)
            caster = sim.components["scan"].caster
            share = caster.rays_cast / caster.rays_total
        assert share < 0.2 if in_numpy else share == 1.0
    for fast, reference in zip(scans[True], scans[False], strict=True):
        assert fast.stamp == reference.stamp
        assert np.array_equal(np.isinf(fast.ranges), np.isinf(reference.ranges))
        assert np.allclose(fast.ranges, reference.ranges, rtol=0, atol=1e-9)
        assert np.allclose(fast.points, reference.points, rtol=0, atol=1e-9)
