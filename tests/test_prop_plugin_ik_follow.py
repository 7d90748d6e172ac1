"""``ik_arm``'s joint-space paths (``FollowJoints``) against the arm's joint limits read from the world.

docs/arm.md: a path outside the joint limits fails ("joint path outside the joint limits") and moves nothing. For
every arm joint, on either side, a waypoint a generated margin past the limit (first, middle or last of the path)
fails; the same path a margin inside the limits is taken. The limits come from the world's joint table, not the
plugin.
"""

from __future__ import annotations

import numpy as np

from robokit.msgs.arm import FollowJoints
from robokit.testing import make_sim

SCENE = {"robots": {"panda": {"urdf": "franka_panda/panda.urdf", "position": [0, 0, 0], "fixed_base": True}},
         "actuators": {"arm": {"type": "ik_arm", "body": "panda", "ee_link": "panda_grasptarget",
                               "ready_pose": {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8,
                                             "panda_joint7": 0.785}}}}
NAMES = tuple(f"panda_joint{i}" for i in range(1, 8))


def test_a_joint_path_past_either_limit_of_any_joint_fails_and_one_inside_is_taken() -> None:
    rng = np.random.default_rng(7)
    with make_sim(SCENE) as sim:
        w, arm = sim.world, sim.components["arm"]
        body = w.body("panda")
        limits = {j.name: (j.lower, j.upper) for j in w.joints(body) if j.name in NAMES}
        start = np.array([s[0] for s in w.joint_states(body, [w.joint(body, n).index for n in NAMES])])
        for k, name in enumerate(NAMES):
            lo, hi = limits[name]
            for side in ("lower", "upper"):
                margin = float(rng.uniform(0.005, 0.2))
                edge = lo if side == "lower" else hi
                sign = -1.0 if side == "lower" else 1.0
                where = int(rng.integers(0, 3))  # the offending waypoint: first, middle or last of three
                for outside in (True, False):
                    q = start.copy()
                    q[k] = edge + sign * margin if outside else edge - sign * margin
                    path = [start.copy(), start.copy(), start.copy()]
                    path[where] = q
                    arm.command(FollowJoints(NAMES, tuple(tuple(float(v) for v in p) for p in path)))
                    r = arm.read()
                    if outside:
                        assert r.failed and r.reason == "joint path outside the joint limits", (name, side, r)
                    else:
                        assert not r.failed, (name, side, r.reason)
                arm.command(FollowJoints(NAMES, (tuple(float(v) for v in start),)))  # back to a held start
