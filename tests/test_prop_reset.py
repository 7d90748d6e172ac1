"""A reset restores "exactly as after a fresh build", compared on the full state of every body.

robokit.gym's ``env.reset(seed=s)`` promises the start state of a fresh build (docs/gym.md, "Same seed, same
episode"): every body's poses, velocities and joint states, every component's start state, no cached contacts.
Here an env that ran a generated history of episodes (random seeds, lengths and actions) is reset and compared with a
freshly built env reset with the same seed -- not on the observation vector alone but on everything the World tells
about every body: base pose (link and centre-of-mass frames), velocities, every link's pose and velocity, joint
positions and velocities, dynamics (mass, frictions, restitution) of every link, colours, what is attached to what,
every constraint with its settings, the engine's parameters and the clock. Then both run the same actions and must
stay bit-identical.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest.importorskip("gymnasium")  # robokit[gym]; the test extra installs it

import robokit.gym  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted((ROOT / "configs" / "gym").glob("*.toml"))
ENGINES = ["pybullet", "mujoco"]


def world_state(world: Any) -> dict[str, Any]:
    """Everything the World interface says about every registered body, as plain Python values."""
    out: dict[str, Any] = {"tick": world.tick, "time": world.time}
    ids = {name: world.body(name) for name in world.body_names}
    for name, bid in sorted(ids.items()):
        joints = world.joints(bid)
        links = [-1, *range(len(joints))]
        states = world.joint_states(bid, [j.index for j in joints]) if joints else []
        out[name] = {
            "pose": world.pose(bid), "com_pose": world.com_pose(bid), "velocity": world.velocity(bid),
            "links": [world.pose(bid, i) for i in links[1:]],
            "link_velocities": [world.link_velocity(bid, i) for i in links[1:]],
            "joints": [(s[0], s[1]) for s in states],
            "dynamics": [world.dynamics(bid, i) for i in links],
            "rgba": world.visual_rgba(bid),
            "joined": sorted(other for other_name, other in ids.items() if other != bid and world.joined(bid, other)),
            "attached": sorted(world.attached(bid)),
        }
    out["engine"] = engine_state(world)
    return out


def engine_state(world: Any) -> dict[str, Any]:
    """What the engine holds besides the bodies: its parameters and every constraint with its settings."""
    if world.engine == "pybullet":
        c = world.client
        uids = [c.getConstraintUniqueId(i) for i in range(c.getNumConstraints())]
        return {"parameters": c.getPhysicsEngineParameters(),
                "constraints": [(uid, c.getConstraintInfo(uid), c.getConstraintState(uid)) for uid in uids]}
    m, d = world.compiled()
    opt = {name: np.asarray(getattr(m.opt, name)).tolist()
           for name in ("timestep", "gravity", "iterations", "ls_iterations", "tolerance", "impratio", "cone",
                        "integrator", "solver", "noslip_iterations", "disableflags", "enableflags")}
    motors = {name: np.asarray(getattr(m, name)).tolist()  # what the joint motors write into the model
              for name in ("actuator_gainprm", "actuator_biasprm", "actuator_forcelimited", "actuator_forcerange",
                           "dof_armature")}
    return {"parameters": opt, "motors": motors, "controls": d.ctrl.tolist(),
            "constraints": [sorted(world.joins.held.items()), d.eq_active.tolist(), m.eq_data.tolist()]}


def flat(obs: Any) -> np.ndarray:
    return np.concatenate([np.ravel(v) for v in obs.values()]) if isinstance(obs, dict) else np.asarray(obs)


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where two nested states differ (exact comparison: a reset promises bit-identical episodes)."""
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return [f"{where}: keys {sorted(a)} != {sorted(b)}"]
        return [d for k in a for d in differences(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{where}[{i}]")]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


@pytest.fixture(scope="module", params=[(c, e) for e in ENGINES for c in CONFIGS],
                ids=lambda p: f"{p[0].stem}-{p[1]}")
def used(request: pytest.FixtureRequest) -> Iterator[tuple[Path, str, Any]]:
    """One env per config and engine that keeps running episodes across the examples (a growing history)."""
    config, engine = request.param
    env = robokit.gym.make(config, world__engine=engine)
    yield config, engine, env
    env.close()


episodes = st.lists(st.tuples(st.integers(0, 2**16), st.integers(0, 25), st.integers(0, 2**16)), max_size=3)


@settings(max_examples=3, deadline=None, derandomize=True, phases=[Phase.explicit, Phase.generate],  # no shrinking:
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])  # an example is an env
@given(history=episodes, seed=st.integers(0, 2**16), action_seed=st.integers(0, 2**16))
def test_reset_after_any_history_equals_a_fresh_build(used: tuple[Path, str, Any], history: list, seed: int,
                                                      action_seed: int) -> None:
    config, engine, env = used
    for s, steps, a in history:
        env.reset(seed=s)
        rng = np.random.default_rng(a)
        for _ in range(steps):
            env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
    fresh = robokit.gym.make(config, world__engine=engine)
    try:
        obs_used, _ = env.reset(seed=seed)
        obs_fresh, _ = fresh.reset(seed=seed)
        assert differences(world_state(env.world), world_state(fresh.world)) == []
        assert np.array_equal(flat(obs_used), flat(obs_fresh))
        rng = np.random.default_rng(action_seed)
        for _ in range(8):
            act = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            a, b = env.step(act), fresh.step(act)
            assert np.array_equal(flat(a[0]), flat(b[0])) and a[1:4] == b[1:4]
            if a[2] or a[3]:
                break
        assert differences(world_state(env.world), world_state(fresh.world)) == []
    finally:
        fresh.close()


# ------------------------------------------------------------------------------------------ World.snapshot/restore
SCENE = {
    "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
               "a": {"shape": "box", "size": [0.1, 0.1, 0.1], "position": [0.5, 0, 0.05]},
               "b": {"shape": "box", "size": [0.1, 0.1, 0.1], "position": [0.52, 0.01, 0.16]},
               "ball": {"shape": "sphere", "radius": 0.05, "position": [0.8, 0.3, 0.3]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
}


@pytest.fixture(scope="module", params=ENGINES)
def restored_sim(request: pytest.FixtureRequest) -> Iterator[Any]:
    from robokit.testing import make_sim

    with make_sim(SCENE, overrides={"world.engine": request.param}) as sim:
        yield sim, sim.world.snapshot()  # the start state every example goes back to


@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(moves=st.lists(st.tuples(st.sampled_from(["a", "b", "ball", "robot"]),
                                st.tuples(*(st.floats(-0.5, 0.5),) * 3), st.floats(-3, 3)), max_size=4),
       steps=st.integers(0, 60), wheels=st.tuples(st.floats(-20, 20), st.floats(-20, 20)))
def test_world_restore_then_steps_equal_a_fresh_build(restored_sim: Any, moves: list, steps: int,
                                                      wheels: tuple) -> None:
    """``World.restore``: 'the next episode runs as one after a fresh build' -- after pushes, teleports and wheel
    spins, a restored world steps exactly as a freshly built one (contacts of a stacked pair included)."""
    from robokit.testing import make_sim

    sim, start = restored_sim
    w = sim.world
    robot = w.body("robot")
    for name, (dx, dy, dz), spin in moves:
        pos, orn = w.pose(name)
        w.set_pose(name, [pos[0] + dx, pos[1] + dy, max(pos[2] + dz, 0.2)], orn)
        w.reset_joint(robot, w.joint(robot, "left_wheel").index, spin, spin)
    for _ in range(steps):
        w.step()
    w.restore(start)
    engine = sim.config.world.engine
    with make_sim(SCENE, overrides={"world.engine": engine}) as fresh:
        assert differences(world_state(w), world_state(fresh.world)) == []
        for world in (w, fresh.world):
            r = world.body("robot")
            for _ in range(40):  # torque lasts one step: no motor setting outlives the example
                for joint, torque in zip(("left_wheel", "right_wheel"), wheels, strict=True):
                    world.set_joint_motor(r, world.joint(r, joint).index, "torque", force=torque * 0.05)
                world.step()
        assert differences(world_state(w), world_state(fresh.world)) == []


@pytest.mark.parametrize("engine", ENGINES)
def test_taking_a_snapshot_changes_nothing_of_the_next_steps(engine: str) -> None:
    """Taking a snapshot only reads: a world that took one steps exactly as one that did not (its engine
    parameters and constraints included)."""
    from robokit.testing import make_sim

    overrides = {"world.engine": engine}
    with make_sim(SCENE, overrides=overrides) as a, make_sim(SCENE, overrides=overrides) as b:
        a.world.snapshot()
        for _ in range(40):
            a.world.step()
            b.world.step()
        assert differences(world_state(a.world), world_state(b.world)) == []
