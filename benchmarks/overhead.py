"""Framework overhead: the drop-test scene stepped by robokit's loop vs. a hand-written pybullet loop.

Both loops do the same work every tick: read the pose and velocity of every dynamic body (33 of them), track each
body's peak bounce height, apply the timed push at t = 2 s, and step the physics. The scene is built the same way
for both (from ``configs/drop_test.toml``); only the loops are timed. Runs alternate to share any drift of the
machine, and the ratio of the medians is printed.

    python benchmarks/overhead.py [--ticks 1200] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from robokit.testing import make_sim

CONFIG = Path(__file__).resolve().parent.parent / "configs" / "drop_test.toml"


def robokit_loop(ticks: int) -> float:
    """Seconds robokit's scheduler takes for ``ticks`` ticks of the drop test."""
    with make_sim(CONFIG, seed=3) as sim:
        start = time.perf_counter()
        sim.step(ticks)
        return time.perf_counter() - start


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
    rk, hand = [], []
    for i in range(args.repeats):
        order = (robokit_loop, hand_loop) if i % 2 == 0 else (hand_loop, robokit_loop)
        for fn in order:
            (rk if fn is robokit_loop else hand).append(fn(args.ticks))
    m_rk, m_hand = statistics.median(rk), statistics.median(hand)
    print(f"drop-test scene, {args.ticks} ticks x {args.repeats} repeats (median)")
    print(f"  hand-written pybullet loop: {m_hand * 1e3:8.1f} ms  ({m_hand / args.ticks * 1e6:6.1f} us/tick)")
    print(f"  robokit loop:               {m_rk * 1e3:8.1f} ms  ({m_rk / args.ticks * 1e6:6.1f} us/tick)")
    print(f"  ratio robokit / hand-written: {m_rk / m_hand:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
