"""A replay at every pose sample against the world it was recorded from, on the full state of every body.

docs/records.md promises: a pose sample at the **start** of every ``round(240 / pose_hz)``-th tick and one of the final
state, ``t = tick x time_step``; ``base/<body>`` the base's pose and ``joints/<body>`` the movable joints' positions in
the header's order, all NaN once a body is removed; and a replay (the page's, the exports') draws every link's world
pose at every ``every``-th sample and the last one. The oracle is the world itself: a monitor of the test's own, in the
loop beside the recorder, reads every body's base pose, every joint's position and every link frame's world pose
straight from PyBullet at the same ticks (and after the last tick). The inputs are generated: the arm's joint
waves, a box's start pose (any rotation), when a ball is removed, the pose rate and the replay's stride.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import rotation

import robokit
from robokit.core.result import jsonable
from robokit.record.format import RunRecord
from robokit.record.recorder import Recorder
from robokit.record.replay import replay_of
from robokit.record.scene import rebuild

CART = Path(__file__).resolve().parents[1] / "robokit" / "data" / "robots" / "diffbot.urdf"


def scene(joints: list[tuple[int, float, float]], box: tuple[float, ...], removed_at: float, duration: float) -> str:
    waves = "".join(f"[actuators.joints.sine.lbr_iiwa_joint_{j}]\namplitude = {a}\nfrequency_hz = {f}\n"
                    for j, a, f in joints)
    x, y, roll, pitch, yaw = box
    return f"""
[world]
max_time = {duration}

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[robots.cart]
urdf = "{CART}"
position = [-0.5, -0.7, 0.4]
rpy_deg = [0, 0, 70]

[bodies.box]
shape = "box"
size = [0.12, 0.06, 0.2]
position = [{x}, {y}, 0.5]
rpy_deg = [{roll}, {pitch}, {yaw}]

[bodies.ball]
shape = "sphere"
radius = 0.05
position = [-0.6, 0.4, 0.3]

[[events]]
at = {removed_at}
type = "remove"
body = "ball"

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
{waves}
[behaviour]
type = "record"
components = []
duration = {duration}
"""


class Watch:
    """The world read at the start of every ``period``-th tick with PyBullet's own calls: per body present, its
    base centre-of-mass pose, every joint's position by name, and every link frame's world pose by link name (the
    base's URDF frame from its inertial offset, worked out here with matrices)."""

    kind = "monitor"

    def __init__(self, world: Any, period: int) -> None:
        self.world, self.period = world, period
        self.seen: dict[int, dict[str, Any]] = {}
        self.started = dt.datetime.now(dt.timezone.utc)

    def sample(self, tick: int) -> None:
        client, out = self.world.client, {}
        for name in self.world.body_names:
            bid = self.world.body(name)
            pos, orn = client.getBasePositionAndOrientation(bid)
            joints, links = {}, {}
            local = client.getDynamicsInfo(bid, -1)
            base = np.eye(4)
            base[:3, :3], base[:3, 3] = rotation(orn), pos
            inertial = np.eye(4)
            inertial[:3, :3], inertial[:3, 3] = rotation(local[4]), local[3]
            links[(client.getBodyInfo(bid)[0].decode() or "base")] = base @ np.linalg.inv(inertial)
            for j in range(client.getNumJoints(bid)):
                info = client.getJointInfo(bid, j)
                joints[info[1].decode()] = client.getJointState(bid, j)[0]
                state = client.getLinkState(bid, j, computeForwardKinematics=True)
                frame = np.eye(4)
                frame[:3, :3], frame[:3, 3] = rotation(state[5]), state[4]
                links[info[12].decode()] = frame
            link_names = [*links]  # by PyBullet's link index + 1: the base first
            visuals = [(link_names[s[1] + 1], s[2], s[3], s[5], s[6], s[7]) for s in client.getVisualShapeData(bid)]
            out[name] = {"com": (np.array(pos), np.array(orn)), "joints": joints, "links": links, "visuals": visuals}
        self.seen[tick] = out


def record_run(folder: Path, text: str, pose_hz: float) -> tuple[RunRecord, Watch, Any, list[dict[str, Any]]]:
    from robokit.core.simulation import Simulation
    from robokit.sweep.trial import build_trial_config, plugins_for

    plugins = plugins_for(())
    (folder / "scene.toml").write_text(text, encoding="utf-8")
    cfg = build_trial_config(text, str(folder / "scene.toml"), folder, {}, plugins)
    run = folder / "results" / "run"  # the results folder is made with the run's
    other = pb.connect(pb.DIRECT)  # a client of its own before the run's (as a video's renderer has): ids differ
    pb.createMultiBody(1.0, pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.1, physicsClientId=other),
                       basePosition=[3, 3, 3], physicsClientId=other)
    sim = Simulation(cfg, plugins, gui=False, seed=3, run_id="run", run_dir=run)
    try:
        recorder = Recorder(sim, run, pose_hz=pose_hz)
        sim.add_monitor(recorder)
        watch = Watch(sim.world, recorder.period)
        sim.add_monitor(watch)
        started = dt.datetime.now(dt.timezone.utc).replace(microsecond=0)
        result = sim.run()
        watch.sample(sim.world.tick)  # the final state
        watch.started = started
        recorder.finish(result)
        traced = json.loads(json.dumps(jsonable(sim.trace)))
    finally:
        sim.close()
        pb.disconnect(other)
    assert recorder.write_poses() == []
    return RunRecord(run), watch, result, traced


def same_rotation(q: Any, r: np.ndarray) -> bool:
    return bool(np.allclose(rotation(q), r, atol=2e-5))


runs = st.tuples(
    st.lists(st.tuples(st.sampled_from([1, 2, 3, 4, 5]), st.floats(0.2, 1.2), st.floats(0.5, 3.0)), min_size=1,
             max_size=3, unique_by=lambda w: w[0]),
    st.tuples(st.floats(0.4, 0.8), st.floats(-0.5, 0.5), st.floats(-180, 180), st.floats(-80, 80),
              st.floats(-180, 180)),
    st.floats(0.02, 0.18),  # before the run ends (it lasts 0.2 s at least)
    st.sampled_from([30, 45, 60, 240, 7, 0.5]),
    st.integers(1, 5),
    st.floats(0.2, 0.35),
)


@pytest.mark.slow  # a recorded run, its replay and a rebuilt scene per example: ~0.3 s each
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(runs)
def test_every_sample_and_every_replayed_link_is_the_world_at_that_tick(
        tmp_path_factory: pytest.TempPathFactory, example: Any) -> None:
    check(tmp_path_factory.mktemp("replay"), *example)


def test_one_run_off_the_sample_grid_with_a_stride_of_three(tmp_path: Path) -> None:
    """The same check on one run: 0.29 s (70 ticks, the last off the grid of 8), a box turned about every axis,
    the ball removed at 0.1 s, a replay of every third sample."""
    ticks = check(tmp_path, [(2, 0.9, 1.5), (4, 0.7, 2.5)], (0.6, 0.2, 35.0, -50.0, 120.0), 0.1, 30, 3, 0.29)
    assert ticks[-1] % 8 and ticks[-2] == ticks[-1] - ticks[-1] % 8  # a final sample of its own


def check(folder: Path, joints: list[tuple[int, float, float]], box: tuple[float, ...], removed_at: float, hz: float,
          every: int, duration: float) -> list[int]:
    rec, watch, result, traced = record_run(folder, scene(joints, box, removed_at, duration), hz)
    poses, header = rec.poses, rec.header
    # the trace read back: every record the run traced, in order, whole, then the end record of the result
    assert rec.events == [*traced, {"kind": "end", "tick": result.ticks, "t": result.sim_time,
                                    "outcome": result.outcome, "reason": result.reason}]
    assert [e["tick"] for e in rec.events] == sorted(e["tick"] for e in rec.events)
    for e in rec.events:
        assert e["t"] == pytest.approx(e["tick"] * header["time_step"], abs=1e-6), e
    assert any(e.get("type") == "remove" and e.get("body") == "ball" for e in traced)
    assert header["seed"] == 3 and header["time_step"] == pytest.approx(1 / 240)
    # the header's every documented field, from the config file and the world
    source = folder / "scene.toml"
    assert (header["kind"], header["schema"], header["robokit_version"], header["run_id"]) == (
        "header", "robokit.record/1", robokit.__version__, "run")
    assert (header["config_path"], header["config_dir"]) == (str(source.resolve()), str(folder.resolve()))
    assert header["config_text"] == source.read_text(encoding="utf-8") and header["config"]["robots"]["cart"]
    created = dt.datetime.fromisoformat(header["created_at"])
    assert created.utcoffset() == dt.timedelta(0) and watch.started - dt.timedelta(seconds=5) <= created
    assert created <= watch.started + dt.timedelta(seconds=1)
    assert set(header["bodies"]) == set(watch.seen[0])
    for name, info in header["bodies"].items():
        assert info["links"] == list(watch.seen[0][name]["links"]), name  # the base link first, then by index
    period = max(1, round(240 / hz))
    ticks = sorted(set(range(0, result.ticks + 1, period)) | {result.ticks})
    # the samples: at every period-th tick from 0 and the final one, t = tick x time_step
    assert poses["tick"].tolist() == ticks == sorted(watch.seen)
    assert poses["t"].tolist() == [k * header["time_step"] for k in ticks]
    assert header["pose_hz"] == pytest.approx(240 / period)
    assert (poses["t"].dtype, poses["tick"].dtype) == (np.float64, np.int64)
    assert {str(a.dtype) for k, a in poses.items() if k.startswith(("base/", "joints/"))} == {"float32"}
    removal = math.ceil(round(removed_at * 240, 6))
    for n, k in enumerate(ticks):
        world = watch.seen[k]
        for name, info in header["bodies"].items():
            base = poses[f"base/{name}"][n]
            if name not in world:
                assert name == "ball" and k >= removal and np.isnan(base).all(), (name, k)
                if f"joints/{name}" in poses:
                    assert np.isnan(poses[f"joints/{name}"][n]).all()
                continue
            pos, orn = world[name]["com"]
            assert base[:3] == pytest.approx(pos, abs=2e-6), (name, k)
            assert same_rotation(base[3:], rotation(orn)), (name, k)
            if info["joints"]:
                assert poses[f"joints/{name}"][n] == pytest.approx(
                    [world[name]["joints"][j] for j in info["joints"]], abs=2e-6), (name, k)
    assert "ball" in watch.seen[ticks[0]] and "ball" not in watch.seen[ticks[-1]]

    # the replay at every `every`-th sample and the last: each link frame where the world had it, NaN once removed
    replay = replay_of(rec, every)
    chosen = sorted(set(range(0, len(ticks), every)) | {len(ticks) - 1})
    assert replay.t.tolist() == [poses["t"][i] for i in chosen]
    drawn = {(link.body, link.link) for link in replay.links}
    for body in ("kuka", "cart", "box", "ball"):
        assert any(b == body for b, _ in drawn), body
    assert {link for b, link in drawn if b == "kuka"} == set(watch.seen[0]["kuka"]["links"])  # every link drawn
    # every visual shape of the world, fixed to its link as the world has it: kind, size, pose in the link, colour
    kinds = {2: "sphere", 3: "box", 4: "cylinder", 5: "mesh", 6: "plane", 7: "capsule"}
    shown = sorted((replay.links[v.frame].body, replay.links[v.frame].link, v.kind, v.size, v.position, v.quaternion,
                    v.rgba if v.kind != "mesh" else ()) for v in replay.shapes)
    had = sorted((body, link, kinds[kind], tuple(size), tuple(position), tuple(orn), tuple(rgba) if kind != 5 else ())
                 for body, seen in watch.seen[0].items() for link, kind, size, position, orn, rgba in seen["visuals"])
    assert len(shown) == len(had)
    for a, b in zip(shown, had, strict=True):
        assert a[:3] == b[:3] and np.allclose(np.hstack(a[3:]), np.hstack(b[3:]), atol=1e-6), (a, b)
    for n, i in enumerate(chosen):
        world = watch.seen[ticks[i]]
        for k, link in enumerate(replay.links):
            got = replay.poses[n, k]
            if link.body not in world:
                assert np.isnan(got).all(), (link.path, ticks[i])
                continue
            want = world[link.body]["links"][link.link]
            assert got[:3] == pytest.approx(want[:3, 3], abs=2e-5), (link.path, ticks[i])
            assert same_rotation(got[3:], want[:3, :3]), (link.path, ticks[i])

    # a rebuilt scene put in a sample's pose holds every joint of every body where the world had it
    with rebuild(rec) as rebuilt:
        client = rebuilt.world.client
        for i in chosen:
            rebuilt.set_frame(i)
            world = watch.seen[ticks[i]]
            for name in world:
                bid = rebuilt.world.body(name)
                for j in range(client.getNumJoints(bid)):
                    jname = client.getJointInfo(bid, j)[1].decode()
                    assert client.getJointState(bid, j)[0] == pytest.approx(world[name]["joints"][jname],
                                                                             abs=2e-6), (name, jname)
    return ticks


def test_a_rate_of_zero_keeps_no_pose_log_and_says_so_in_the_header(tmp_path: Path) -> None:
    text = "[world]\nmax_time = 0.05\n\n[bodies.box]\nshape = \"box\"\nposition = [0, 0, 1]\n"
    from robokit.core.simulation import Simulation
    from robokit.sweep.trial import build_trial_config, plugins_for

    plugins = plugins_for(())
    cfg = build_trial_config(text, "scene.toml", tmp_path, {}, plugins)
    sim = Simulation(cfg, plugins, gui=False, seed=0, run_id="run", run_dir=tmp_path / "run")
    try:
        recorder = Recorder(sim, tmp_path / "run", pose_hz=0)
        sim.add_monitor(recorder)
        recorder.finish(sim.run())
    finally:
        sim.close()
    assert recorder.write_poses() == []
    rec = RunRecord(tmp_path / "run")
    assert rec.header["pose_hz"] == 0 and not rec.has_poses and rec.events[-1]["kind"] == "end"
    assert rec.header["config_text"] is None and rec.header["config_path"] == "scene.toml"
