"""gripper ``watch_settling = false``: no finger-joint reads between readings, the same physics, ``settled`` read
from the finger speed (the gym pick env ships with it)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

import robokit.gym
from robokit.msgs.arm import GripperCommand
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
PICK = ROOT / "configs" / "gym" / "pick.toml"


def counting_joint_reads(world: Any) -> list[int]:
    """Count the world's joint-state queries from now on (the list holds the count)."""
    calls = [0]
    real = world.joint_states

    def joint_states(*args: Any, **kwargs: Any) -> Any:
        calls[0] += 1
        return real(*args, **kwargs)

    world.joint_states = joint_states
    return calls


def rollout(watch: bool, steps: int = 60) -> tuple[list[np.ndarray], int]:
    """Seeded random actions in the pick env (one reset on the way): observations, and joint reads per step."""
    env = robokit.gym.make(PICK, actuators__gripper__watch_settling=watch)
    try:
        rng = np.random.default_rng(3)
        obs, _ = env.reset(seed=5)
        calls = counting_joint_reads(env.unwrapped.sim.world)
        out = [obs]
        for i in range(steps):
            obs, *_ = env.step(rng.uniform(-1.0, 1.0, 4).astype(np.float32))
            out.append(obs)
            if i == steps // 2:
                obs, _ = env.reset(seed=6)
                out.append(obs)
        return out, calls[0]
    finally:
        env.close()


def test_pick_env_without_the_watch_gives_the_same_observations_with_fewer_joint_reads() -> None:
    watched, watched_reads = rollout(True)
    shipped, shipped_reads = rollout(False)
    assert len(watched) == len(shipped)
    for a, b in zip(watched, shipped, strict=True):
        assert np.array_equal(a, b)  # reads never move anything: the physics is bit-identical
    # watched: the gripper's own read on each of the 20 physics ticks of a step, on top of the observation's
    assert shipped_reads <= watched_reads - 15 * 60


SCENE: dict[str, Any] = {
    "robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
    "actuators": {"gripper": {"type": "gripper", "body": "panda", "watch_settling": False}},
}


def test_unwatched_settled_is_the_finger_speed_when_read() -> None:
    with make_sim(SCENE) as sim:
        calls = counting_joint_reads(sim.world)
        sim.components["gripper"].command(GripperCommand("close"))
        sim.step(5)
        assert calls[0] == 0  # nothing read the gripper: nothing read its joints
        g = sim.readings["gripper"]
        # closing on nothing at up to 0.2 m/s a finger: moving, so not settled
        assert not g.settled
        assert 0.0 < g.width < 0.08
        for _ in range(240):
            sim.step(1)
            if sim.readings["gripper"].width < 1e-3:
                break
        sim.step(10)
        g = sim.readings["gripper"]
        assert g.width < 1e-3 and g.settled  # closed on nothing and still
