"""patrol_collect with a gripper on a lift (configs/patrol_pickup.toml): the can is moved by contacts only and
ends inside the bin, judged tick by tick from the world; the scripted stow is shown to fail the same oracle."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import tomllib

from robokit.planning.dock import Bin, BinConfig
from robokit.testing import make_sim

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "patrol_pickup.toml"
BIN_AREA = ((0.7, 3.35), (1.3, 4.0))  # written out again here: the oracle does not read the behaviour's config
FINGERS = {"left_finger_link", "right_finger_link"}
DT = 1.0 / 240.0
MAX_STEP = 0.5 * DT + 0.002  # m per tick: faster than the robot ever drives (0.4 m/s), plus settling slack


def one_can_scene(can_xy: tuple[float, float]) -> dict[str, Any]:
    """The shipped pickup scene with one can at a fixed spot and a single nearby waypoint."""
    cfg = tomllib.loads(CONFIG.read_text(encoding="utf-8"))
    cfg["world"]["max_time"] = 150.0
    can = cfg["bodies"]["can"]
    for key in ("region", "count"):
        can.pop(key)
    can["position"] = [can_xy[0], can_xy[1], 0.1]
    cfg["regions"].pop("floor")
    cfg["sensors"]["truth"]["bodies"] = ["can"]
    cfg["behaviour"]["waypoints"] = [[0.5, -1.2]]
    return cfg


class CanWatch:
    """Per tick: the can's position and which links of the robot (and which other bodies) touch it."""

    def __init__(self, sim: Any, can: str = "can") -> None:
        self.world = sim.world
        self.can, self.robot = self.world.body(can), self.world.body("robot")
        self.names = {-1: self.world.base_link_name(self.robot)}
        self.names.update({j.index: j.child_link for j in self.world.joints(self.robot)})
        self.rows: list[tuple[tuple[float, float, float], set[str], set[str]]] = []

    def sample(self) -> None:
        links, others = set(), set()
        for c in self.world.contacts(self.can):
            if c.other == self.robot:
                links.add(self.names[c.other_link])
            else:
                others.add(self.world.body_name(c.other) or str(c.other))
        self.rows.append((tuple(self.world.pose(self.can)[0]), links, others))


def watch_run(sim: Any, watch: CanWatch, max_ticks: int) -> None:
    for _ in range(max_ticks):
        sim.step(1)
        watch.sample()
        if sim.outcome is not None:
            return


def contact_only_violations(rows: list) -> list[str]:
    """Ticks where the can jumped, or moved with no robot contact in the last 2 s (falling and settling after a
    release take well under that)."""
    out, last_touch = [], -10**9
    for i in range(1, len(rows)):
        (p0, _, _), (p1, links, _) = rows[i - 1], rows[i]
        if links or rows[i - 1][1]:
            last_touch = i
        step = math.dist(p0, p1)
        if step > MAX_STEP:
            out.append(f"tick {i}: jumped {step * 1000:.1f} mm")
        elif step > 2e-4 and i - last_touch > 2.0 / DT:
            out.append(f"tick {i}: moved {step * 1000:.2f} mm with no robot contact for {(i - last_touch) * DT:.1f} s")
    return out


@pytest.mark.slow
def test_the_gripper_carries_the_can_into_the_bin_by_contacts_only() -> None:
    with make_sim(one_can_scene((1.4, -0.6)), base_dir=CONFIG.parent) as sim:
        watch = CanWatch(sim)
        start = watch.world.pose("can")[0]
        watch_run(sim, watch, int(150 / DT))
        outcome = sim.outcome
        assert outcome is not None and outcome.status == "succeeded", getattr(outcome, "reason", "still running")
        rows = watch.rows
        assert contact_only_violations(rows) == []
        # Before any finger touched it the can stood where it was put.
        first = next(i for i, (_, links, _) in enumerate(rows) if links)
        assert max(math.dist(start, p) for p, _, _ in rows[:first]) < 1e-3
        # Lifted (bottom 3 cm off the floor): held by both fingers and by nothing else.
        lifted = [(links, others) for (_, _, z), links, others in rows if z > 0.13]
        assert len(lifted) > 10 / DT, "carried for at least 10 sim s"
        assert all(FINGERS <= links and not others for links, others in lifted)
        # It travelled: from the floor where it stood to inside the bin, resting, untouched by the robot.
        (x, y, z), links, _ = rows[-1]
        (x0, y0), (x1, y1) = BIN_AREA
        assert x0 < x < x1 and y0 < y < y1, (x, y)
        assert z < 0.12 and not links
        assert math.dist(start[:2], (x, y)) > 3.0
        result = sim.behaviour.result()
        assert result["mechanism"] == "gripper" and result["objects_collected"] == 1


@pytest.mark.slow
def test_the_scripted_stow_fails_the_contact_only_oracle() -> None:
    """The stow that the plain diffbot uses places the can by program: the same oracle catches the jump."""
    cfg = tomllib.loads((ROOT / "configs" / "patrol_robot.toml").read_text(encoding="utf-8"))
    can = cfg["bodies"]["can"]
    for key in ("region", "count"):
        can.pop(key)
    can["position"] = [1.4, -0.6, 0.1]
    cfg["regions"].pop("floor")
    cfg["sensors"]["truth"]["bodies"] = ["can"]
    cfg["behaviour"]["waypoints"] = [[0.5, -1.2]]
    with make_sim(cfg, base_dir=CONFIG.parent) as sim:
        watch = CanWatch(sim)
        watch_run(sim, watch, int(60 / DT))
        assert sim.outcome is not None and sim.outcome.status == "succeeded"
        assert any("jumped" in v for v in contact_only_violations(watch.rows))


def test_bin_slots_fill_from_the_far_side_and_stay_inside() -> None:
    """Bin geometry against hand-computed values: a 0.6 x 0.65 m pen, mouth on its south edge, facing north."""
    b = Bin(BinConfig(area=BIN_AREA, mouth=(1.0, 3.35), inward_deg=90.0), object_radius=0.05, reach=0.28)
    assert b.depth == pytest.approx(0.65)
    assert [round(b.slot_depth(k), 3) for k in range(6)] == [0.57, 0.46, 0.35, 0.24, 0.13, 0.08]
    assert b.stage == pytest.approx((1.0, 3.35 - 0.8))
    assert b.along(1.1, 3.55) == pytest.approx((0.2, -0.1))
    assert b.held_at((1.0, 3.0, math.pi / 2)) == pytest.approx((1.0, 3.28))
    assert b.contains(1.0, 3.9) and not b.contains(1.0, 3.3)
    # Docking: heading straight in on the centre line drives forward; past the slot it stops.
    twist, left = b.dock((1.0, 3.0, math.pi / 2), 0)
    assert left == pytest.approx(0.57 - (3.28 - 3.35)) and twist.v > 0 and abs(twist.omega) < 1e-9
    twist, left = b.dock((1.0, 3.65, math.pi / 2), 0)
    assert left < 0 and twist.v == 0 and twist.omega == 0
    # Facing away: turn in place first.
    twist, _ = b.dock((1.0, 2.5, -math.pi / 2), 0)
    assert twist.v == 0 and abs(twist.omega) > 0
