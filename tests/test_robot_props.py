"""Properties of the robot checker, over generated inputs, against independent oracles.

- Any rigid body is a set of point masses: its inertia sum(m (|r|² I - r rᵀ)), turned by any rotation, is
  physically possible, so the ``inertia`` check never refuses it; a diagonal inertia whose largest moment exceeds
  the sum of the two others is impossible, so the check always refuses it.
- The diffdrive scaffold, for any wheel radius, chassis and mass in a student's range with the track wider than the
  chassis plus a wheel, passes every check (no false alarm across the parameter space); with the chassis wider than
  the track plus a wheel, the ``wheels`` check refuses it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.robot.check import check_robot, load, static_problems
from robokit.robot.model import Link, Robot

PROPS = settings(max_examples=60, deadline=None, derandomize=True)
SLOW_PROPS = settings(max_examples=30, deadline=None, derandomize=True)
XACRO = Path(__file__).resolve().parent.parent / "robokit" / "data" / "robots" / "scaffold" / "diffdrive.urdf.xacro"


def _one_link(mass: float, inertia: np.ndarray) -> Robot:
    link = Link(name="body", line=1, mass=mass, inertia=(inertia[0, 0], inertia[0, 1], inertia[0, 2],
                                                         inertia[1, 1], inertia[1, 2], inertia[2, 2]))
    return Robot(name="one", path=Path("one.urdf"), links=[link], joints=[])


def _rotation(q: list[float]) -> np.ndarray:
    x, y, z, w = np.asarray(q) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


points = st.lists(st.tuples(st.floats(0.01, 5.0), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5),
                            st.floats(-0.5, 0.5)), min_size=4, max_size=12)
quaternions = st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: sum(v * v for v in q) > 0.01)


@PROPS
@given(points, quaternions)
def test_any_body_made_of_point_masses_has_a_possible_inertia(cloud: list[tuple[float, float, float, float]],
                                                              q: list[float]) -> None:
    masses = np.array([c[0] for c in cloud])
    r = np.array([c[1:] for c in cloud])
    r -= (masses[:, None] * r).sum(axis=0) / masses.sum()  # about the centre of mass
    inertia = sum(m * (np.dot(p, p) * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, r, strict=True))
    rot = _rotation(q)
    turned = rot @ inertia @ rot.T
    if np.linalg.eigvalsh(turned)[0] <= 1e-9 * np.trace(turned):  # all points on one line (or one point)
        return
    assert static_problems(_one_link(float(masses.sum()), turned)) == []


@PROPS
@given(st.floats(1e-4, 10), st.floats(1e-4, 10), st.floats(1.001, 3), st.floats(0.1, 10))
def test_a_largest_moment_above_the_sum_of_the_others_is_refused(a: float, b: float, excess: float,
                                                                 mass: float) -> None:
    inertia = np.diag([a, b, (a + b) * excess])
    [problem] = static_problems(_one_link(mass, inertia))
    assert problem.check == "inertia" and "triangle inequality" in problem.message


designs = st.fixed_dictionaries({
    "wheel_radius": st.floats(0.03, 0.12), "wheel_width": st.floats(0.02, 0.06),
    "chassis_length": st.floats(0.2, 0.5), "chassis_width": st.floats(0.12, 0.4),
    "chassis_height": st.floats(0.04, 0.12), "chassis_mass": st.floats(0.5, 8.0), "gap": st.floats(0.01, 0.1)})


@pytest.mark.slow
@SLOW_PROPS
@given(designs)
def test_the_scaffold_passes_whenever_the_track_clears_the_chassis(design: dict[str, float]) -> None:
    args = dict(design)
    gap = args.pop("gap")
    args["track"] = args["chassis_width"] + args["wheel_width"] + gap
    assert [p.text("bot") for p in check_robot(load(XACRO, args))] == []


@pytest.mark.slow
@SLOW_PROPS
@given(designs)
def test_the_scaffold_is_refused_when_the_chassis_buries_its_wheels(design: dict[str, float]) -> None:
    args = dict(design)
    gap = args.pop("gap")
    args["track"] = args["chassis_width"] - args["wheel_width"] - gap  # both wheels wholly inside the chassis
    found = {(p.check, p.where) for p in check_robot(load(XACRO, args))}
    assert {("wheels", "joint 'left_wheel'"), ("wheels", "joint 'right_wheel'")} <= found
