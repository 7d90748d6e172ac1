"""Framework overhead: scenes stepped by robokit's loop vs. a hand-written pybullet loop doing the same work.

- **panda** (the main job's scene from ``configs/sort_robot.toml``: Panda, table, two trays, four cubes): every
  tick, seven sine-wave joint targets go to the arm as position-control motor commands, the pose and velocity of
  the four cubes are read and their peak heights tracked (the ``drop_test`` behaviour), and the physics steps.
  The typical robokit workload: a robot, contacts, a few tracked objects.
- **dance** (``configs/kuka_dance.toml``, lesson 03): every tick, seven sine-wave joint targets are computed and
  sent as position-control motor commands and the physics steps; ten times a sim second the joint states are read
  and recorded. A typical robot loop: the physics step dominates.
- **drop** (``configs/drop_test.toml``, lesson 01): every tick, the pose and velocity of all 33 dynamic bodies are
  read, each body's peak bounce is tracked, the timed push is applied at t = 2 s, and the physics steps. A
  sensor-heavy worst case: 66 state queries a tick.

Each scene is built the same way for both loops; only the loops are timed. Runs alternate to share any drift of
the machine; the ratio of the medians is printed.

    python benchmarks/overhead.py [--ticks 1200] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from robokit.testing import make_sim

CONFIGS = Path(__file__).resolve().parent.parent / "configs"
CONFIG = CONFIGS / "drop_test.toml"
DANCE = CONFIGS / "kuka_dance.toml"
PANDA_JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
CUBES = ["red_0", "red_1", "blue_0", "blue_1"]


def panda_config() -> dict:
    """The main job's bodies, with a joint-space dance of the arm and the cubes' states tracked every tick."""
    import tomllib

    raw = tomllib.loads((CONFIGS / "sort_robot.toml").read_text())
    ready = [0.0, -0.4, 0.0, -2.2, 0.0, 1.8, 0.8]
    return {
        "world": raw["world"], "regions": raw["regions"], "bodies": raw["bodies"], "robots": raw["robots"],
        "sensors": {"poses": {"type": "body_pose", "bodies": CUBES}},
        "actuators": {"joints": {"type": "joint_control", "body": "panda", "joints": PANDA_JOINTS,
                                 "max_force": 200.0, "position_gain": 0.1,
                                 "sine": {n: {"amplitude": 0.3, "frequency_hz": 0.25 + 0.05 * i, "offset": ready[i]}
                                          for i, n in enumerate(PANDA_JOINTS)}}},
        "behaviour": {"type": "drop_test", "duration": 1000.0},
    }


def hand_panda(ticks: int) -> float:
    """Seconds a hand-written loop takes for the panda scene's work (built by the same config)."""
    import math

    import pybullet as p

    with make_sim(panda_config(), seed=3) as sim:
        world = sim.world
        cid, panda = world.cid, world.body("panda")
        program = sim.config.actuators[0].params.sine
        indices = [world.joint("panda", n).index for n in PANDA_JOINTS]
        waves = [(w.offset, w.amplitude, 2 * math.pi * w.frequency_hz, math.radians(w.phase_deg))
                 for w in (program[n] for n in PANDA_JOINTS)]
        forces, gains = [200.0] * 7, [0.1] * 7
        cubes = [world.body(n) for n in CUBES]
        last_vz = dict.fromkeys(cubes, 0.0)
        peak: dict[int, float] = {}
        start = time.perf_counter()
        for k in range(ticks):
            for b in cubes:
                pos, _orn = p.getBasePositionAndOrientation(b, physicsClientId=cid)
                lin, _ang = p.getBaseVelocity(b, physicsClientId=cid)
                z, vz = pos[2], lin[2]
                if b not in peak:
                    if last_vz[b] < -0.05 and vz >= 0.0:
                        peak[b] = z
                elif z > peak[b]:
                    peak[b] = z
                last_vz[b] = vz
            t = k / 240.0
            targets = [off + amp * math.sin(om * t + ph) for off, amp, om, ph in waves]
            p.setJointMotorControlArray(panda, indices, p.POSITION_CONTROL, targetPositions=targets, forces=forces,
                                        positionGains=gains, physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
        elapsed = time.perf_counter() - start
        FINAL["hand panda"] = [s[0] for s in p.getJointStates(panda, indices, physicsClientId=cid)]
        return elapsed


FINAL: dict[str, list[float]] = {}
"""Final joint positions of the dance in each loop: the two loops must end in the same state."""


def robokit_loop(ticks: int, config: Path | str = CONFIG) -> float:
    """Seconds robokit's scheduler takes for ``ticks`` ticks of a scene."""
    with make_sim(panda_config() if config == "panda" else config, seed=3) as sim:
        start = time.perf_counter()
        sim.step(ticks)
        elapsed = time.perf_counter() - start
        if config in (DANCE, "panda"):
            FINAL[f"robokit {'panda' if config == 'panda' else 'dance'}"] = list(
                sim.readings["joints"].positions.values())
        return elapsed


def hand_dance(ticks: int) -> float:
    """Seconds a hand-written loop takes to drive the dance: sine targets every tick, states at 10 Hz."""
    import math

    import pybullet as p

    with make_sim(DANCE, seed=3) as sim:
        world = sim.world
        cid, kuka = world.cid, world.body("kuka")
        program = sim.config.actuators[0].params.sine
        joints = [(world.joint("kuka", name).index, wave) for name, wave in program.items()]
        indices = [i for i, _ in joints]
        waves = [(w.offset, w.amplitude, 2 * math.pi * w.frequency_hz, math.radians(w.phase_deg)) for _, w in joints]
        forces, gains = [200.0] * len(joints), [0.1] * len(joints)
        log = []
        start = time.perf_counter()
        for k in range(ticks):
            t = k / 240.0
            targets = [off + amp * math.sin(om * t + ph) for off, amp, om, ph in waves]
            p.setJointMotorControlArray(kuka, indices, p.POSITION_CONTROL, targetPositions=targets, forces=forces,
                                        positionGains=gains, physicsClientId=cid)
            if k % 24 == 0:
                states = p.getJointStates(kuka, indices, physicsClientId=cid)
                log.append([(s[0], s[1], s[3]) for s in states])
            p.stepSimulation(physicsClientId=cid)
        elapsed = time.perf_counter() - start
        final = [s[0] for s in p.getJointStates(kuka, indices, physicsClientId=cid)]
        FINAL["hand dance"] = final
        return elapsed


def hand_loop(ticks: int) -> float:
    """Seconds a hand-written pybullet loop takes for the same work on the same scene."""
    import pybullet as p

    with make_sim(CONFIG, seed=3) as sim:  # the same bodies; the loop below uses raw pybullet calls only
        world = sim.world
        cid = world.client._client
        names = sim.components["poses"].names
        ids = [world.body(n) for n in names]
        box = world.body("box")
        push_start, push_ticks = round(2.0 * 240), round(0.05 * 240)
        last_vz = dict.fromkeys(ids, 0.0)
        peak: dict[int, float] = {}
        start = time.perf_counter()
        for k in range(ticks):
            for b in ids:
                pos, _orn = p.getBasePositionAndOrientation(b, physicsClientId=cid)
                lin, _ang = p.getBaseVelocity(b, physicsClientId=cid)
                z, vz = pos[2], lin[2]
                if b not in peak and last_vz[b] < -0.05 and vz >= 0.0:
                    peak[b] = z
                if b in peak:
                    peak[b] = max(peak[b], z)
                last_vz[b] = vz
            if push_start <= k < push_start + push_ticks:
                at, _ = p.getBasePositionAndOrientation(box, physicsClientId=cid)
                p.applyExternalForce(box, -1, (60, 0, 0), at, p.WORLD_FRAME, physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
        return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=1200)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    scenes = (("panda", "panda", hand_panda), ("dance", DANCE, hand_dance), ("drop", CONFIG, hand_loop))
    for label, config, hand_fn in scenes:
        rk, hand = [], []
        for i in range(args.repeats):  # alternate the order so drift hits both alike
            if i % 2 == 0:
                rk.append(robokit_loop(args.ticks, config))
                hand.append(hand_fn(args.ticks))
            else:
                hand.append(hand_fn(args.ticks))
                rk.append(robokit_loop(args.ticks, config))
        m_rk, m_hand = statistics.median(rk), statistics.median(hand)
        name = "sort_robot.toml bodies" if config == "panda" else Path(config).name
        print(f"{label} scene ({name}), {args.ticks} ticks x {args.repeats} repeats (median)")
        print(f"  hand-written pybullet loop: {m_hand * 1e3:8.1f} ms  ({m_hand / args.ticks * 1e6:6.1f} us/tick)")
        print(f"  robokit loop:               {m_rk * 1e3:8.1f} ms  ({m_rk / args.ticks * 1e6:6.1f} us/tick)")
        print(f"  ratio robokit / hand-written: {m_rk / m_hand:.3f}")
    for label in ("panda", "dance"):
        gap = max(abs(a - b) for a, b in zip(FINAL[f"robokit {label}"], FINAL[f"hand {label}"], strict=True))
        print(f"{label}: largest difference between the two loops' final joint positions: {gap:.2e} rad")
    return 0


if __name__ == "__main__":
    sys.exit(main())
