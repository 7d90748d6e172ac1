"""Contact points on both engines against the geometry of two boxes face to face, over generated rotations.

The World promises (``robokit.engines.interface.Contact``): a contact seen from body A (the queried body) names the
other body B, its ``normal`` points from B to A (a unit vector, world frame), its ``position`` lies on B, its normal
force is not negative; asked the other way round the same contact has the opposite normal. Each example turns a
static slab by a generated rotation (never the identity nor a half turn) and lays a box on the slab's top face,
pressed 1 mm into it, turned about the face's normal by a generated angle: the normal is the slab's top face
normal, its third rotation column, computed here from axis and angle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from engine_inputs import axes, turns
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from oracles import rodrigues

from robokit.engines.interface import World

pytest_plugins = ["engine_props"]

NO_SHRINK = [Phase.explicit, Phase.generate]


def quaternion_of(m: np.ndarray) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of a rotation matrix, from its axis and angle."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(m) - 1.0) / 2.0)))
    axis = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    if np.linalg.norm(axis) < 1e-9:
        return (0.0, 0.0, 0.0, 1.0)
    k = axis / np.linalg.norm(axis) * math.sin(angle / 2.0)
    return (float(k[0]), float(k[1]), float(k[2]), math.cos(angle / 2.0))


@settings(max_examples=15, deadline=None, derandomize=True, phases=NO_SHRINK,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(axis=axes, turn=turns, spin=turns, slab=st.tuples(st.floats(0.3, 0.6), st.floats(0.3, 0.6)),
       box=st.tuples(*(st.floats(0.06, 0.15),) * 3), mass=st.floats(0.2, 2.0))
def test_a_contact_normal_points_from_the_other_body_to_the_queried_one(world: World, axis, turn, spin, slab, box,
                                                                         mass) -> None:
    rot = rodrigues(axis, turn)
    up = rot[:, 2]  # the slab's top face normal
    centre = np.array([0.2, -0.1, 1.0])
    half_slab = np.array([slab[0], slab[1], 0.05]) / 2.0
    half_box = np.asarray(box) / 2.0
    top = rot @ rodrigues((0.0, 0.0, 1.0), spin)  # the box turned about the face normal
    at = centre + up * (half_slab[2] + half_box[2] - 0.001)  # pressed 1 mm into the slab
    a = world.add_primitive("slab", "box", size=tuple(2 * half_slab), mass=0.0, position=tuple(centre),
                            orientation=quaternion_of(rot))
    b = world.add_primitive("box", "box", size=tuple(2 * half_box), mass=mass, position=tuple(at),
                            orientation=quaternion_of(top))
    try:
        world.step()
        for queried, other, sign in ((b, a, 1.0), (a, b, -1.0)):
            points = world.contacts(queried, other)
            assert points, "the box pressed into the slab touches it"
            assert points == [p for p in world.contacts(queried) if p.other == other]
            for p in points:
                assert p.other == other and p.link == -1 and p.other_link == -1
                assert np.asarray(p.normal) == pytest.approx(sign * up, abs=2e-3), "from B to A"
                assert p.normal_force >= 0.0
                # on the surface of B: the slab's top face, or the box's bottom face
                face = half_slab[2] if other == a else -half_box[2]
                origin = centre if other == a else np.asarray(world.pose(b)[0])
                assert (np.asarray(p.position) - origin) @ up == pytest.approx(face, abs=2.5e-3)
    finally:
        world.remove_body("box")
        world.remove_body("slab")
