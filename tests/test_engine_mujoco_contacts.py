"""Contact forces on the mujoco engine are those of the step that solved them: a copy of the state before each step,
solved by MuJoCo alone (``mj_step2``, no robokit code), and decoded by MuJoCo's own ``mj_contactForce``, is the
oracle. Two boxes land one after the other, so the number of contacts changes (0, 4, 8) while they are read: a
contact read where MuJoCo's next, unsolved constraint rows lie would show left-over memory or a neighbour's force."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # as robokit sets it: MuJoCo picks its GL backend when first imported
mujoco = pytest.importorskip("mujoco")

from robokit.core.simulation import build  # noqa: E402

SCENE = {"world": {"engine": "mujoco"},
         "bodies": {"plane": {"urdf": "plane.urdf", "position": [0, 0, 0]},
                    "low": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [0, 0, 0.1]},
                    "high": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 3.0, "position": [0.4, 0, 0.35]}}}


def _oracle(m: object, before: object) -> list[tuple[frozenset[int], float]]:
    """The contacts MuJoCo itself solves from the state ``before`` a step: (geom pair, normal force)."""
    d = mujoco.MjData(m)
    mujoco.mj_copyData(d, m, before)
    mujoco.mj_step2(m, d)
    wrench = np.zeros(6)
    out = []
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, wrench)
        out.append((frozenset(int(g) for g in d.contact.geom[i]), float(wrench[0])))
    return sorted(out, key=lambda c: (sorted(c[0]), c[1]))


def test_every_contact_force_read_is_the_one_mujoco_solved_in_that_step() -> None:
    with build(SCENE) as sim:
        world = sim.world
        m, d = world.compiled()
        plane, low, high = (world.body(n) for n in ("plane", "low", "high"))
        geoms_of = {b: {g for g in range(m.ngeom) if world._geom_owners(m)[g][0] == b} for b in (plane, low, high)}
        counts = set()
        for _ in range(220):
            before = mujoco.MjData(m)
            mujoco.mj_copyData(before, m, d)
            expected = _oracle(m, before)
            world.step()
            read = []
            for box in (low, high):
                for c in world.contacts(box, plane):
                    read.append((c.normal_force, box))
            counts.add(len(read))
            want = sorted(f for pair, f in expected if pair & geoms_of[plane])
            assert sorted(f for f, _ in read) == pytest.approx(want, abs=1e-9)
        assert {0, 4, 8} <= counts  # before the first landing, one box down, both down
        # and at rest the floor carries both boxes
        assert sum(c.normal_force for b in (low, high) for c in world.contacts(b, plane)) == \
            pytest.approx(4.0 * 9.81, rel=0.02)
