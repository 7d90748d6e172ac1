"""``World.restore`` of a snapshot taken while bodies move, on both engines.

The World promises (``robokit.engines.interface.World``): ``snapshot`` keeps "every registered body's state (base pose
and velocity, joint states)" and ``restore`` puts "every body of a snapshot back exactly". A snapshot taken at the
build sees bodies at rest, where a restore that forgot the velocities would look right; here each example throws two
boxes (generated pushes and spins, generated flight time), snapshots them in mid-flight, lets them fly on and land,
restores, and compares every body's pose and velocity with what the world's own getters said at the snapshot.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from robokit.engines.interface import World

BODIES = ("a", "b")
TOLERANCE = {"pybullet": 1e-9, "mujoco": 1e-12}


@pytest.fixture(params=["pybullet", "mujoco"])
def engine(request: pytest.FixtureRequest) -> Iterator[type[World]]:
    try:
        yield World.engine_class(request.param)
    except ImportError as exc:
        pytest.skip(f"engine {request.param!r} not installed: {exc}")


def state(world: World) -> np.ndarray:
    out: list[float] = []
    for name in BODIES:
        (p, q), (v, w) = world.pose(name), world.velocity(name)
        if q[3] < 0:  # q and -q are one orientation
            q = tuple(-x for x in q)
        out += [*p, *q, *v, *w]
    return np.asarray(out, dtype=float)


push = st.tuples(st.floats(-30.0, 30.0), st.floats(-30.0, 30.0), st.floats(20.0, 60.0))


@settings(max_examples=4, deadline=None, derandomize=True, database=None, phases=[Phase.explicit, Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(pushes=st.tuples(push, push), yaw=st.floats(0.2, 2.9), before=st.integers(3, 30), after=st.integers(1, 90))
def test_a_snapshot_taken_in_flight_comes_back_with_its_velocities(engine: type[World], pushes, yaw: float,
                                                                  before: int, after: int) -> None:
    with engine(seed=0) as world:
        world.load_urdf("plane", "plane.urdf")
        turn = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
        world.add_primitive("a", "box", size=(0.1, 0.2, 0.05), mass=0.5, position=(0.0, 0.0, 0.3), orientation=turn)
        world.add_primitive("b", "box", size=(0.08, 0.08, 0.08), mass=0.3, position=(0.6, 0.0, 0.3))
        for name, force in zip(BODIES, pushes, strict=True):  # thrown up and sideways, off-centre: spinning too
            (x, y, z), _ = world.pose(name)
            world.apply_force(name, force, position=(x + 0.02, y - 0.03, z + 0.01))
        for _ in range(before):
            world.step()
        taken = state(world)
        speeds = [np.linalg.norm(taken[13 * i + 7:13 * i + 13]) for i in range(len(BODIES))]
        assert min(speeds) > 0.05, "the boxes move when the snapshot is taken"
        snap = world.snapshot()
        for _ in range(after):
            world.step()
        assert np.abs(state(world) - taken).max() > 1e-3  # they flew on
        world.restore(snap)
        assert world.tick == 0
        back = state(world)
        assert np.abs(back - taken).max() <= TOLERANCE[world.engine], np.round(back - taken, 6).tolist()
