"""pick_place's retries on every branch docs/arm.md names, judged against a scripted cell (no physics) that plays a
fault per attempt: the fingers close on nothing, the cube slips out in LIFT, TRANSPORT or LOWER, the arm stalls in
a state until its timeout, the fingers stick in GRASP or RELEASE, the cube lands off the spot, the arm rejects a
target. Every field of the result is compared with a second computation: the attempts and reasons the script
implies, the phase times summed from the run's transition records, the cube where the cell put it, the grasps the
cell saw, the gripper's yaw folded by hand. A halt at a generated moment is judged by the cell: the arm stays where
it was halted and the cube stays in the fingers."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.msgs.arm import ArmState, GripperCommand, GripperState, HoldArm, MoveTo
from robokit.msgs.body import BodyState
from robokit.testing import ScriptedRun

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_prop_sample_behaviours import Tiny, drive, pick_place  # noqa: E402  (the scripted table of several cubes)

SIZE = 0.05
G = 9.81
DOWN = (1.0, 0.0, 0.0, 0.0)
START = (0.5, -0.05, SIZE / 2)
PLACE = (0.4, 0.25, SIZE / 2)
# the arm moves of one attempt, in the order docs/arm.md lists the states
MOVES = ("APPROACH", "DESCEND", "LIFT", "TRANSPORT", "LOWER", "RETREAT")
FAULTS = ["ok", "miss", "drop:LIFT", "drop:TRANSPORT", "drop:LOWER", "stall:APPROACH", "stall:DESCEND",
          "stall:LIFT", "stall:TRANSPORT", "stall:LOWER", "stall:RETREAT", "stall:GRASP", "stall:RELEASE",
          "misplace", "reject:APPROACH", "reject:DESCEND", "reject:TRANSPORT"]


def quat_z(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


@dataclass
class Cell:
    """One cube, an arm that goes straight to its targets and two fingers; ``faults[k]`` is what goes wrong in the
    k-th attempt (an attempt begins with the fingers opening as the arm sets off above the cube). A cube let go
    falls straight down and lands upright; its pose reading says how fast it falls."""

    faults: list[str]
    yaw: float
    offset: tuple[float, float]
    cube: list[float] = field(default_factory=lambda: list(START))
    arm: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    start: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    target: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    t0: float = 0.0
    t1: float = 0.0
    status: str = "idle"
    reason: str = ""
    command_id: int = 0
    stalled: bool = False
    action: str = "open"
    changed_at: float = 0.0
    stuck: bool = False
    held: bool = False
    attempt: int = -1
    move: int = -1
    grasps: int = 0
    closes: int = 0
    yaws: list[float] = field(default_factory=list)
    speeds: list[tuple[str, float | None]] = field(default_factory=list)
    widths: list[float | None] = field(default_factory=list)
    drops: list[float] = field(default_factory=list)
    misplaced: list[list[float]] = field(default_factory=list)
    fall: tuple[float, float] | None = None
    at_retreat: list[list[float]] = field(default_factory=list)

    @property
    def fault(self) -> str:
        return self.faults[self.attempt] if 0 <= self.attempt < len(self.faults) else "ok"

    def command(self, commands: Any, t: float) -> None:
        grip, arm = commands.get("gripper"), commands.get("arm")
        if isinstance(grip, GripperCommand):
            if grip.action == "open" and isinstance(arm, MoveTo):  # an attempt: open and go above the cube
                self.attempt += 1
                self.move = -1
            self.grip(grip, t)
        if isinstance(arm, MoveTo):
            self.command_id += 1
            self.move += 1
            self.yaws.append(arm.yaw)
            self.speeds.append((MOVES[self.move] if self.move < len(MOVES) else "", arm.speed))
            self.start, self.target, self.t0 = list(self.arm), list(arm.position), t
            self.t1 = t + max(0.02, math.dist(self.arm, arm.position) / (arm.speed or 1.0))
            self.status, self.reason, self.stalled = "moving", "", False
            what = MOVES[self.move] if self.move < len(MOVES) else ""
            if self.fault == f"stall:{what}":
                self.stalled = True
            elif self.fault == f"reject:{what}":
                self.status, self.reason = "failed", "unreachable: scripted"
        elif isinstance(arm, HoldArm):
            self.command_id += 1
            self.target, self.status, self.stalled = list(self.arm), "idle", False

    def grip(self, grip: GripperCommand, t: float) -> None:
        self.action, self.changed_at, self.stuck = grip.action, t, False
        if grip.action == "width":
            self.widths.append(grip.width)
        if grip.action == "open":
            self.let_go(t)
        elif grip.action == "close":
            self.closes += 1
            if self.fault == "stall:GRASP":
                self.stuck = True
            elif self.fault != "miss" and math.dist(self.cube, self.arm) < 0.01:
                self.held = True
                self.grasps += 1
        elif self.fault == "stall:RELEASE":
            self.stuck = True
        else:
            self.let_go(t, self.offset if self.fault == "misplace" else (0.0, 0.0))

    def let_go(self, t: float, shift: tuple[float, float] = (0.0, 0.0)) -> None:
        """The cube leaves the fingers and falls straight down (g) from where it is, shifted by ``shift``."""
        if self.held:
            self.held = False
            self.cube = [self.arm[0] + shift[0], self.arm[1] + shift[1], self.arm[2]]
            self.fall = (t, self.arm[2])
            if shift != (0.0, 0.0):
                self.misplaced.append([*self.cube[:2], SIZE / 2])

    def falling(self, t: float) -> float:
        """The cube's vertical speed now (negative: falling), its height brought up to ``t``."""
        if self.fall is None:
            return 0.0
        t0, z0 = self.fall
        z = z0 - 0.5 * G * (t - t0) ** 2
        if z <= SIZE / 2:
            self.cube[2], self.fall = SIZE / 2, None  # landed, upright, at rest
            return 0.0
        self.cube[2] = z
        return -G * (t - t0)

    def advance(self, t: float) -> None:
        if self.status == "moving" and not self.stalled:
            s = min(1.0, (t - self.t0) / (self.t1 - self.t0))
            self.arm = [a + s * (b - a) for a, b in zip(self.start, self.target, strict=True)]
            if s >= 1.0:
                self.status = "reached"
                if MOVES[self.move] == "RETREAT":
                    self.at_retreat.append(list(self.cube))
            what = MOVES[self.move] if 0 <= self.move < len(MOVES) else ""
            if self.held and self.fault == f"drop:{what}" and s >= 0.5:
                self.drops.append(t)
                self.let_go(t)
        if self.held:
            self.cube = list(self.arm)

    def readings(self, t: float) -> dict[str, Any]:
        self.advance(t)
        vz = self.falling(t)
        if self.held:
            width = SIZE
        elif self.stuck:
            width = SIZE if self.action == "width" else 0.03
        else:
            width = {"open": 0.08, "close": 0.0}.get(self.action, SIZE + 0.025)
        arm = ArmState(tuple(self.arm), DOWN, status=self.status, reason=self.reason,  # type: ignore[arg-type]
                       command_id=self.command_id, target_position=tuple(self.target),  # type: ignore[arg-type]
                       path_end=self.t1 if self.status == "moving" and not self.stalled else None)
        grip = GripperState(width=width, target_width=width, action=self.action,
                            settled=not self.stuck and t - self.changed_at >= 0.03, holding=self.held,
                            held="cube" if self.held else None)
        cube = BodyState(tuple(self.cube), quat_z(self.yaw), (0.0, 0.0, vz), (0.0, 0.0, 0.0))  # type: ignore[arg-type]
        return {"arm": arm, "gripper": grip, "poses": {"cube": cube}}


def build(max_attempts: int, timeout: float) -> ScriptedRun:
    config = {"object": "cube", "pose_sensor": "poses", "place_position": list(PLACE), "object_size": SIZE,
              "max_attempts": max_attempts, "timeouts": {s: timeout for s in (*MOVES, "GRASP", "RELEASE")}}
    return ScriptedRun("pick_place", config, components={"arm": (ArmState, "actuator"),
                                                          "gripper": (GripperState, "actuator"), "poses": dict},
                       bodies=["cube"])


def play(run: ScriptedRun, cell: Cell, until: float = 60.0) -> None:
    commands: Any = {}
    while run.outcome is None and run.t < until - 1e-9:
        cell.command(commands, run.t)
        commands = run.step(cell.readings(run.t))


def expected(faults: list[str], max_attempts: int, timeout: float, misplaced_mm: list[str]) -> tuple[
        str, int, list[str]]:
    """What docs/arm.md says the script leads to: (outcome, attempts, one reason per failed attempt)."""
    reasons: list[str] = []
    misplaced = iter(misplaced_mm)
    for k in range(max_attempts):
        fault = faults[k] if k < len(faults) else "ok"
        kind, _, state = fault.partition(":")
        if kind == "ok":
            return "succeeded", k + 1, reasons
        if kind == "reject":  # an arm that rejects a target fails at once, with the arm's reason
            return "failed", k + 1, [*reasons, f"arm failed in {state}: unreachable: scripted"]
        why = {"miss": "grasp failed: fingers closed to 0.0 mm without holding",
               "drop": f"dropped during {state}",
               "stall": f"timed out in {state} after {timeout:g} s"}.get(kind)
        reasons.append(why if why is not None else f"placed {next(misplaced)} mm from the target")
    last = f" (after {max_attempts} attempt{'s' if max_attempts > 1 else ''})"
    return "failed", max_attempts, [*reasons[:-1], reasons[-1] + last]


def phase_times_from(trace: list[dict[str, Any]]) -> dict[str, float]:
    """Sim seconds per state left, summed over the run's transition records."""
    out: dict[str, float] = {}
    moves = [r for r in trace if r["kind"] == "transition"]
    for before, after in zip(moves, moves[1:], strict=False):
        out[after["source_state"]] = out.get(after["source_state"], 0.0) + after["t"] - before["t"]
    if moves:
        out.setdefault(moves[0]["source_state"], 0.0)
    return out


def fold(yaw: float) -> float:
    """A cube is the same every quarter turn: its yaw brought into [-45, 45) degrees."""
    return (yaw + math.pi / 4) % (math.pi / 2) - math.pi / 4


faults_st = st.lists(st.sampled_from(FAULTS), min_size=1, max_size=4)


@pytest.mark.parametrize("fault", FAULTS)
def test_each_retry_branch_alone_then_a_clean_attempt(fault: str) -> None:
    check_run([fault], 2, 0.55, 0.6, (0.04, -0.02))


@settings(max_examples=15, deadline=None, derandomize=True)
@given(faults_st, st.integers(1, 4), st.sampled_from([0.4, 0.55, 0.75]), st.floats(-1.5, 1.5),
       st.tuples(st.floats(0.03, 0.06), st.floats(-0.06, 0.06)))
def test_every_retry_branch_reports_what_the_cell_did(faults: list[str], max_attempts: int, timeout: float,
                                                      yaw: float, offset: tuple[float, float]) -> None:
    check_run(faults, max_attempts, timeout, yaw, offset)


def check_run(faults: list[str], max_attempts: int, timeout: float, yaw: float, offset: tuple[float, float]) -> None:
    cell = Cell(list(faults), yaw, offset)
    run = build(max_attempts, timeout)
    play(run, cell)
    assert run.outcome is not None, "ended within a minute of sim time"
    result = run.result()
    misplaced = [f"{math.dist(p, PLACE) * 1000:.0f}" for p in cell.misplaced]
    status, attempts, failures = expected(faults, max_attempts, timeout, misplaced)
    assert (run.outcome.status, result["attempts"], result["failures"]) == (status, attempts, failures)
    # the reason: the last failure, or what was placed in how many attempts; the result repeats it
    reason = f"placed cube in {attempts} attempt(s)" if status == "succeeded" else failures[-1]
    assert run.outcome.reason == reason and result["reason"] == reason and result["outcome"] == status
    # one attempt per opening of the fingers over the table; a grasp only where the cube is (located anew)
    assert cell.attempt + 1 == attempts
    assert cell.grasps == cell.closes - sum(f in ("miss", "stall:GRASP") for f in faults[:attempts])
    # where the cube is: on the spot after a success (the cell put it there), the retreat's measurement of it
    assert result["object"] == "cube" and result["place_position"] == list(PLACE)
    assert "jobs" not in result and "placed" not in result  # one job: no list of jobs
    assert result["pick_position"] == list(START)
    if status == "succeeded":
        assert math.dist(cell.cube, PLACE) < 1e-9
    if cell.at_retreat:  # the last attempt that rose clear measured where the cube had landed
        assert math.dist(result["final_position"], cell.at_retreat[-1]) < 1e-12
        assert abs(result["placement_error"] - math.dist(cell.at_retreat[-1], PLACE)) < 1e-12
        assert abs(result["final_yaw"] - yaw) < 1e-9
    else:
        assert result["final_position"] is None and result["placement_error"] is None
        assert result["final_yaw"] is None
    # the phase times: each state's time from the transition records; together, the job's sim time
    times = phase_times_from(run.trace)
    assert result["phase_times"].keys() == times.keys()
    for state, seconds in times.items():
        assert abs(result["phase_times"][state] - seconds) < 3e-6, state
    end = max(r["t"] for r in run.trace if r["kind"] == "transition")
    assert abs(result["sim_time"] - end) < 3e-6 and abs(sum(times.values()) - end) < 1e-5
    # near the cube (down to it, down to the spot) at slow_speed, else at speed; the release opens to the cube + 25 mm
    assert all(v == (0.6 if what in ("DESCEND", "LOWER") else 1.2) for what, v in cell.speeds), cell.speeds
    assert cell.widths and all(abs(w - (SIZE + 0.025)) < 1e-12 for w in cell.widths) or "RELEASE" not in times
    # a drop while the arm moves is noticed within 1/hold_check_hz (60 Hz) and retried at once
    retries = [r["t"] for r in run.trace if r["kind"] == "transition" and r["trigger"] in ("retry", "give_up")]
    for dropped in cell.drops:
        noticed = min(t for t in retries if t >= dropped - 1e-5)
        assert noticed - dropped <= 1 / 60 + 1 / 240 + 1e-6, (dropped, noticed)
    # the wrist turned to the cube's faces: its yaw folded into +-45 degrees, on every move
    assert all(abs(y - fold(yaw)) < 1e-9 for y in cell.yaws), (yaw, set(cell.yaws))


@settings(max_examples=15, deadline=None, derandomize=True)
@given(st.lists(st.sampled_from(["ok", "miss", "drop:TRANSPORT", "stall:LOWER", "misplace"]), min_size=1,
                max_size=3), st.floats(0.02, 2.5))
def test_a_halt_at_any_moment_leaves_the_arm_where_it_was_and_the_cube_in_the_fingers(faults: list[str],
                                                                                      at: float) -> None:
    cell = Cell(list(faults), 0.3, (0.04, 0.0))
    run = build(3, 0.75)
    play(run, cell, until=at)
    if run.outcome is not None:
        return
    cell.command(run.behaviour.halt(run.t) or {}, run.t)
    arm, held, cube = list(cell.arm), cell.held, list(cell.cube)
    for k in range(1, 241):  # a second of the cell with nothing else commanded
        cell.readings(run.t + k / 240)
    assert cell.arm == arm, f"the arm went on from {arm} to {cell.arm} after the halt"
    assert cell.held == held and (not held or cell.cube == arm), "the fingers let go of the cube"
    assert held or cell.cube[:2] == cube[:2]


@pytest.mark.slow
def test_a_cube_lost_high_in_transport_is_picked_where_it_lands() -> None:
    """Real physics (configs/pick_place.toml, two attempts): mid-transport the cube is put 8 cm to the side of the
    fingers, at their height; it falls to the table. The second attempt finds it where it lies and places it: the
    world has it on the spot. (Located while it fell, the second grasp closed on air.)"""
    from robokit.testing import make_sim

    config = Path(__file__).resolve().parents[1] / "configs" / "pick_place.toml"
    with make_sim(config, overrides={"behaviour.max_attempts": 2}) as sim:
        world = sim.world
        while sim.behaviour.state_name != "TRANSPORT" and world.time < 10:
            sim.step(1)
        sim.step(12)
        (x, y, z), orn = world.pose("cube")
        assert z > 0.1, "carried high"
        world.set_pose("cube", [x + 0.08, y, z], orn)
        result = sim.run()
        cube = world.pose("cube")[0]
    assert result.result["failures"] == ["dropped during TRANSPORT"], result.result["failures"]
    assert result.outcome == "succeeded" and result.result["attempts"] == 2, result.reason
    assert math.dist(cube, (0.45, -0.35, 0.027)) < 0.02  # the config's place_position, within its tolerance


@settings(max_examples=8, deadline=None, derandomize=True)
@given(st.lists(st.lists(st.sampled_from(["ok", "miss", "drop"]), min_size=1, max_size=3), min_size=2, max_size=3),
       st.integers(1, 3), st.booleans())
def test_each_job_of_a_stack_has_its_own_record_and_the_run_sums_them(plans: list[list[str]], max_attempts: int,
                                                                      by_position: bool) -> None:
    """``objects = [...]`` (or ``pick_positions``, the cubes' places given in the reverse order: each job is the
    cube found there): each object is a job with its own record (object, attempts, failures, outcome, reason,
    place position on the stack so far, times); the run's reason sums the jobs' attempts, or names the job that
    failed, k of n; ``placed`` counts the jobs that placed. Judged by the scripted table of
    tests/test_prop_sample_behaviours.py (which grasps hold) and where it put each cube."""
    cubes = [f"cube{i}" for i in range(len(plans))]
    objects = {n: [0.45 + 0.08 * i, -0.1, SIZE / 2] for i, n in enumerate(cubes)}
    names = cubes[::-1] if by_position else cubes  # the jobs' order
    plans = plans[::-1] if by_position else plans
    spot = [0.4, 0.25, SIZE / 2]
    world = Tiny({k: list(v) for k, v in objects.items()}, dict(zip(names, plans, strict=True)))
    if by_position:
        config = {"pick_positions": [objects[n] for n in names], "pose_sensor": "poses", "place_position": spot,
                  "object_size": SIZE, "max_attempts": max_attempts}
        run = ScriptedRun("pick_place", config, components={"arm": (ArmState, "actuator"),
                                                             "gripper": (GripperState, "actuator"), "poses": dict},
                          bodies=cubes)
    else:
        run = pick_place(objects, spot, max_attempts=max_attempts)
    drive(run, world, 60.0)
    result = run.result()
    jobs, placed, total = result["jobs"], 0, 0
    for k, (name, plan) in enumerate(zip(names, plans, strict=True)):
        tried = [plan[min(i, len(plan) - 1)] for i in range(max_attempts)]
        attempts = tried.index("ok") + 1 if "ok" in tried else max_attempts
        why = {"miss": "grasp failed: fingers closed to 0.0 mm without holding", "drop": "dropped during LIFT"}
        failures = [why[g] for g in tried[:attempts] if g != "ok"]
        job = jobs[k]
        assert (job["object"], job["attempts"]) == (name, attempts) == (name, world.grasps[name])
        assert job["place_position"] == pytest.approx([*spot[:2], spot[2] + placed * SIZE])  # on the stack so far
        assert abs(sum(job["phase_times"].values()) - job["sim_time"]) < 1e-5
        total += attempts
        if "ok" not in tried:
            last = f"{failures[-1]} (after {attempts} attempt{'s' if attempts > 1 else ''})"
            reason = f"object {k + 1} of {len(names)} ({name}): {last}"
            assert job["failures"] == [*failures[:-1], last]  # one per attempt; the reason names the job
            assert (job["outcome"], job["reason"]) == ("failed", reason)
            assert len(jobs) == k + 1 and (run.outcome.status, run.outcome.reason) == ("failed", reason)
            break
        assert (job["failures"], job["outcome"], job["reason"]) == (failures, "succeeded",
                                                                    f"placed {name} in {attempts} attempt(s)")
        assert world.objects[name] == pytest.approx([*spot[:2], SIZE / 2 + placed * SIZE])  # the table has it there
        placed += 1
    else:
        assert len(jobs) == len(names)
        assert (run.outcome.status, run.outcome.reason) == ("succeeded", f"placed {placed} objects in {total} "
                                                                         "attempt(s)")
    assert result["placed"] == placed and result["attempts"] == jobs[-1]["attempts"]
