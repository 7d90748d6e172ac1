"""ik_arm: poses reached within 5 mm on two arms (Panda, Kuka iiwa), unreachable targets, smooth paths."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from robokit.msgs.arm import HoldArm, MoveTo, down_quaternion, quat_angle
from robokit.testing import PLANE, make_sim

PANDA_READY = {"panda_joint2": -0.4, "panda_joint4": -2.2, "panda_joint6": 1.8, "panda_joint7": 0.785}
KUKA_READY = {"lbr_iiwa_joint_2": 0.6, "lbr_iiwa_joint_4": -1.4, "lbr_iiwa_joint_6": 1.25}  # flange down, yaw pi


def scene(urdf: str, ee_link: str, ready: dict[str, float], **arm: Any) -> dict[str, Any]:
    return {
        "bodies": {"plane": PLANE},
        "robots": {"robot": {"urdf": urdf, "position": [0, 0, 0], "fixed_base": True}},
        "actuators": {"arm": {"type": "ik_arm", "body": "robot", "ee_link": ee_link, "ready_pose": ready, **arm}},
    }


def move(sim: Any, cmd: Any, max_ticks: int = 960) -> Any:
    """Send a command, step until the arm reports reached/failed; return the final reading."""
    sim.components["arm"].command(cmd)
    sim.step(1)
    sim.run_until(lambda s: s.readings["arm"].status in ("reached", "failed"), max_ticks)
    return sim.readings["arm"]


def true_ee_pose(sim: Any, link: str) -> tuple[np.ndarray, Any]:
    pos, orn = sim.world.pose("robot", sim.world.link("robot", link))
    return np.array(pos), orn


PANDA_POSES = [((0.5, 0.0, 0.3), 0.0), ((0.45, 0.25, 0.1), 0.6), ((0.6, -0.2, 0.05), -0.7),
               ((0.35, -0.3, 0.4), 1.2), ((0.3, 0.3, 0.2), 0.0)]
KUKA_POSES = [((0.5, 0.0, 0.5), math.pi), ((0.4, 0.3, 0.4), math.pi + 0.5), ((0.55, -0.2, 0.3), math.pi - 0.5),
              ((0.3, -0.3, 0.6), math.pi + 0.2)]


@pytest.mark.parametrize(
    ("urdf", "ee_link", "ready", "poses"),
    [("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY, PANDA_POSES),
     ("kuka_iiwa/model.urdf", "lbr_iiwa_link_7", KUKA_READY, KUKA_POSES)],
    ids=["panda", "kuka_iiwa"],
)
def test_reaches_poses_within_5mm(urdf: str, ee_link: str, ready: dict[str, float], poses: list[Any]) -> None:
    with make_sim(scene(urdf, ee_link, ready)) as sim:
        for target, yaw in poses:
            reading = move(sim, MoveTo(target, yaw=yaw))
            assert reading.status == "reached", reading.reason
            pos, orn = true_ee_pose(sim, ee_link)
            assert np.linalg.norm(pos - target) < 0.005, (target, pos)
            assert quat_angle(orn, down_quaternion(yaw)) < 0.05


def test_unreachable_target_fails_with_reason_and_the_arm_stays() -> None:
    with make_sim(scene("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY)) as sim:
        before = move(sim, MoveTo((0.5, 0.0, 0.3)))
        assert before.reached
        joints_before = dict(sim.readings["arm"].joint_positions)
        reading = move(sim, MoveTo((1.4, 0.0, 0.2)))
        assert reading.status == "failed"
        assert reading.reason.startswith("unreachable: IK residual")
        assert "(1.400, 0.000, 0.200)" in reading.reason
        sim.step(120)  # no flailing: the arm holds where it was
        after = sim.readings["arm"].joint_positions
        assert max(abs(after[k] - joints_before[k]) for k in joints_before) < 1e-3
        # a new reachable target works again after a failure
        assert move(sim, MoveTo((0.45, 0.1, 0.25))).reached


def test_reach_limit_rejects_at_once() -> None:
    with make_sim(scene("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY, reach=0.85)) as sim:
        reading = move(sim, MoveTo((0.9, 0.0, 0.5)), max_ticks=2)
        assert reading.failed
        assert "from the base, reach is 0.85 m" in reading.reason


def test_path_is_smooth_and_takes_the_configured_speed() -> None:
    with make_sim(scene("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY, speed=0.5)) as sim:
        arm = sim.components["arm"]
        arm.command(MoveTo((0.5, -0.2, 0.15)))
        start = np.array(sim.readings["arm"].position)
        targets, positions = [], []
        for _ in range(400):
            sim.step(1)
            targets.append(arm.q_cmd.copy())
            positions.append(np.array(sim.readings["arm"].position))
            if sim.readings["arm"].reached:
                break
        assert sim.readings["arm"].reached
        steps = np.abs(np.diff(np.array(targets), axis=0)).max()
        assert steps < 0.01  # rad per tick: no jumps between waypoints
        dist = np.linalg.norm(np.array(positions[-1]) - start)
        path_time = len(positions) / 240.0
        assert path_time >= 1.5 * dist / 0.5 - 0.01  # the smooth profile's peak speed is the configured speed
        # close to a straight line: every point within 1 cm of the segment
        seg = (np.array((0.5, -0.2, 0.15)) - start) / np.linalg.norm(np.array((0.5, -0.2, 0.15)) - start)
        off = [np.linalg.norm((p - start) - ((p - start) @ seg) * seg) for p in positions]
        assert max(off) < 0.01


def test_hold_cancels_a_path() -> None:
    with make_sim(scene("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY)) as sim:
        arm = sim.components["arm"]
        arm.command(MoveTo((0.5, 0.3, 0.1)))
        sim.step(60)
        arm.command(HoldArm())
        sim.step(60)
        here = np.array(sim.readings["arm"].position)
        sim.step(60)
        assert np.linalg.norm(np.array(sim.readings["arm"].position) - here) < 0.002
        assert sim.readings["arm"].status == "idle"
        assert math.dist(here, (0.5, 0.3, 0.1)) > 0.05


def test_batched_path_solve_equals_waypoint_by_waypoint() -> None:
    """A path's IK answers checked in one batched FK pass give exactly the sequential solutions, including a
    path whose far end needs the numpy fallback (out of PyBullet IK's tolerance) and one out of reach."""
    from robokit_plugins.ik_arm import _slerp

    with make_sim(scene("franka_panda/panda.urdf", "panda_grasptarget", PANDA_READY)) as sim:
        arm = sim.components["arm"]
        q0 = arm._measured_all()
        start_pos, start_orn = arm.chain.fk(q0)
        positions, _ = arm.chain.fk_many(np.array([q0, q0]))
        assert np.array_equal(positions[0], start_pos) and np.array_equal(positions[1], start_pos)
        fallbacks = []
        numpy_solver = arm._solve_numpy
        arm._solve_numpy = lambda *a: fallbacks.append(1) or numpy_solver(*a)
        for goal, yaw in [((0.5, 0.1, 0.2), 0.3), ((0.35, -0.3, 0.05), -1.2), ((0.85, 0.0, 0.05), 0.0),
                          ((1.3, 0.2, 0.3), 0.5)]:
            orn = down_quaternion(yaw)
            poses = [(start_pos + k / 12 * (np.array(goal) - start_pos), _slerp(start_orn, orn, k / 12))
                     for k in range(1, 13)]
            batched = arm._solve_path(q0, poses)
            q, sequential = q0, []
            for pos, o in poses:
                q, ep, eo = arm._solve(q, pos, o)
                sequential.append((q, ep, eo))
            for (qa, epa, eoa), (qb, epb, eob) in zip(batched, sequential, strict=True):
                assert np.array_equal(qa, qb)
                assert epa == pytest.approx(epb, abs=1e-12) and eoa == pytest.approx(eob, abs=1e-9)
        assert fallbacks  # the numpy solver took over somewhere: the fallback path was exercised
        assert arm.read().path_end is None  # no path commanded yet
        arm.command(MoveTo((0.5, 0.1, 0.2)))
        reading = arm.read()
        assert reading.status == "moving" and reading.path_end == pytest.approx(arm.t0 + arm.duration)
