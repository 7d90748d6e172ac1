"""patrol's legs, collisions and record against a scripted yard: the patrol is set up on a real world (its map read
from the bodies' boxes: a static box, a flat static pad that is floor, a loose crate) and then driven by hand, a
unicycle that follows its twists at the behaviour's rate. The yard's own geometry is the oracle: a waypoint is
reached at the first step the robot is within the tolerance of it, missed at the first step its leg has lasted more
than waypoint_timeout (each leg timed from the step the one before ended, the first from the patrol's first step,
however late that comes); a collision is the robot's disk starting to overlap the box (never the pad or the crate);
the distance is the yard's odometer. Every result field, the reason, the trace and the drive's last command are
compared with that (docs/mobile.md, "patrol")."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.msgs.mobile import STOP, DriveState, Twist
from robokit.testing import PLANE, make_sim

RATE = 20.0
TOLERANCE = 0.2  # NavConfig's documented default
DISK = 0.15  # the yard's robot: a disk this wide in radius touches what it overlaps
BOX = ((1.3, -0.2), (1.7, 0.2))  # the static box's footprint, the only body of the known map
PAD = ((0.25, 0.75), (0.75, 1.25))  # static and 1 cm high: floor, not map
CRATE = ((0.7, -0.9), (0.9, -0.7))  # loose: not map
CANDIDATES = [(2.5, 0.0), (0.5, 1.0), (0.8, -0.8), (-0.6, 0.5), (2.4, 0.7), (0.3, -0.3)]


def yard(waypoints: list[tuple[float, float]], laps: int, timeout: float) -> dict[str, Any]:
    def box(lo: tuple[float, float], hi: tuple[float, float], height: float, mass: float) -> dict[str, Any]:
        return {"shape": "box", "size": [hi[0] - lo[0], hi[1] - lo[1], height], "mass": mass,
                "position": [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, height / 2]}

    return {"bodies": {"plane": PLANE, "box_a": box(*BOX, 0.3, 0), "pad": box(*PAD, 0.01, 0),
                       "crate": box(*CRATE, 0.2, 0.5)},
            "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
            "actuators": {"drive": {"type": "diff_drive", "robot": "robot"}},
            "behaviour": {"type": "patrol", "rate_hz": RATE, "scan": "", "waypoints": [list(w) for w in waypoints],
                          "laps": laps, "waypoint_timeout": timeout}}


def overlaps(x: float, y: float, footprint: tuple[tuple[float, float], tuple[float, float]]) -> bool:
    (x0, y0), (x1, y1) = footprint
    return math.hypot(x - min(max(x, x0), x1), y - min(max(y, y0), y1)) < DISK


class Yard:
    """The robot as a unicycle on the yard: the twist commanded at a step holds until the next."""

    def __init__(self) -> None:
        self.x = self.y = self.theta = self.distance = 0.0
        self.twist = STOP

    def drive(self, commands: Any) -> None:
        if isinstance(commands.get("drive"), Twist):
            self.twist = commands["drive"]
        dt = 1 / RATE
        self.x += self.twist.v * math.cos(self.theta) * dt
        self.y += self.twist.v * math.sin(self.theta) * dt
        self.theta += self.twist.omega * dt
        self.distance += abs(self.twist.v) * dt

    def touching(self) -> tuple[str, ...]:
        bodies = (("box_a", BOX), ("pad", PAD), ("crate", CRATE))
        names = ["plane"] + [n for n, f in bodies if overlaps(self.x, self.y, f)]
        return tuple(sorted(names))

    def reading(self) -> DriveState:
        pose = (self.x, self.y, self.theta)
        return DriveState(pose, self.twist.v, self.twist.omega, pose, self.distance, (0.0, 0.0), self.touching(),
                          self.twist)


@settings(max_examples=6, deadline=None, derandomize=True)
@example([0, 3, 2], 1, 8.0, 1.35)  # through the box and back, by the crate: two collisions with the box
@given(st.lists(st.sampled_from(range(len(CANDIDATES))), min_size=1, max_size=3), st.integers(1, 2),
       st.sampled_from([2.0, 3.5, 8.0]), st.sampled_from([0.0, 1.35]))
def test_every_leg_collision_and_figure_of_a_patrol_against_the_yard(picks: list[int], laps: int, timeout: float,
                                                                     t0: float) -> None:
    waypoints = [CANDIDATES[i] for i in picks]
    with make_sim(yard(waypoints, laps, timeout)) as sim:
        patrol = sim.behaviour
        assert {b.name for b in patrol.map} == {"box_a"}, "the map: the static box, not the pad or the crate"
        before = len(sim.trace)
        robot = Yard()
        legs, leg, began = len(waypoints) * laps, 0, t0
        visits: list[tuple[str, dict[str, Any]]] = []
        touching: set[str] = set()
        collisions: list[dict[str, Any]] = []
        commands: Any = {}
        t = t0
        while patrol.outcome is None and t < t0 + legs * timeout + 5:
            reading = robot.reading()
            now = set(reading.contacts) & {"box_a"}
            collisions += [{"t": round(t, 3), "body": n} for n in sorted(now - touching)]
            touching = now
            # the yard's judgement of the leg, by the documented rule, on the pose the patrol is given
            goal = waypoints[leg % len(waypoints)]
            if math.hypot(robot.x - goal[0], robot.y - goal[1]) <= TOLERANCE:
                ended = "waypoint_reached"
            elif t - began > timeout:
                ended = "waypoint_missed"
            else:
                ended = ""
            commands = patrol.step({"drive": reading}, t) or {}
            if ended:
                visits.append((ended, {"waypoint": leg % len(waypoints), "lap": leg // len(waypoints),
                                       "t": round(t, 3)}))
                leg, began = leg + 1, t
            last_t, odometer = t, reading.distance
            robot.drive(commands)
            t = round(t + 1 / RATE, 9)
        assert patrol.outcome is not None and leg == legs, "the patrol ended after its last leg"
        result = patrol.result()
        traced = [(r["kind"], {k: r[k] for k in ("waypoint", "lap", "t")}) for r in sim.trace[before:]
                  if r["kind"] in ("waypoint_reached", "waypoint_missed")]
        traced_hits = [r["body"] for r in sim.trace[before:] if r["kind"] == "collision"]
        halt = patrol.halt(last_t)
    assert traced == visits
    reached = [v for k, v in visits if k == "waypoint_reached"]
    missed = legs - len(reached)
    assert result["visits"] == reached
    assert (result["waypoints_total"], result["waypoints_reached"], result["waypoints_missed"]) == (
        legs, len(reached), missed)
    assert result["collision_events"] == collisions and result["collisions"] == len(collisions)
    assert traced_hits == [c["body"] for c in collisions]
    assert result["distance_travelled"] == round(odometer, 3)
    assert result["sim_time"] == round(last_t, 3)
    if missed:
        assert (patrol.outcome.status, patrol.outcome.reason) == (
            "failed", f"missed {missed} of {legs} waypoint visits")
    else:
        assert (patrol.outcome.status, patrol.outcome.reason) == (
            "succeeded", f"visited all {legs} waypoints at t = {last_t:.2f} s")
    assert commands == {"drive": STOP}, "the last leg's end stops the drive"
    assert halt == {"drive": STOP}


@settings(max_examples=5, deadline=None, derandomize=True)
@given(st.lists(st.sets(st.sampled_from(["plane", "box_a", "pad", "crate"])), min_size=1, max_size=12))
def test_named_map_bodies_are_the_map_and_the_only_bodies_a_collision_counts(touches: list[set[str]]) -> None:
    """``map_bodies = ["crate", "pad"]``: the map is those two, as boxes with their footprints in the world (the
    crate is loose, the pad flat: named, they count), and the box, not named, is no obstacle; each new touch of a
    map body is one collision, in the result and the trace."""
    cfg = yard([(2.5, 0.0)], 1, 8.0)
    cfg["behaviour"]["map_bodies"] = ["crate", "pad"]
    with make_sim(cfg) as sim:
        patrol = sim.behaviour
        boxes = {b.name: (b.lo, b.hi) for b in patrol.map}
        assert boxes.keys() == {"crate", "pad"}
        for name, (lo, hi) in (("crate", CRATE), ("pad", PAD)):
            assert all(abs(a - b) < 0.01 for a, b in zip((*boxes[name][0], *boxes[name][1]), (*lo, *hi),
                                                          strict=True)), (name, boxes[name])
        before = len(sim.trace)
        for k, names in enumerate(touches):
            patrol.count_collisions({"drive": _touching(names)}, k / RATE)
        result = patrol.result()
        traced = [r["body"] for r in sim.trace[before:] if r["kind"] == "collision"]
    expected, was = [], set()
    for k, names in enumerate(touches):
        now = names & {"crate", "pad"}
        expected += [{"t": round(k / RATE, 3), "body": n} for n in sorted(now - was)]
        was = now
    assert result["collision_events"] == expected and result["collisions"] == len(expected)
    assert traced == [e["body"] for e in expected]


def _touching(names: set[str]) -> DriveState:
    return DriveState((0.0, 0.0, 0.0), 0.0, 0.0, (0.0, 0.0, 0.0), 0.0, (0.0, 0.0), tuple(sorted(names)))
