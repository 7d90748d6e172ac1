"""pick_place against a small scripted world (no physics): an arm that reaches its targets, fingers that grasp
or miss as scripted per attempt, objects that follow the fingers and fall where they are let go. What the machine
reports (attempts per object, outcome) is compared with the script, where it carries an object with where the docs
say it flies, and what it leaves the actuators doing when it is halted with the docs' promise."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.msgs.arm import ArmState, GripperCommand, GripperState, HoldArm, MoveTo
from robokit.msgs.body import BodyState
from robokit.testing import ScriptedRun

SIZE = 0.05
DOWN = (1.0, 0.0, 0.0, 0.0)


@dataclass
class Tiny:
    """The scripted world: ``outcomes[name]`` is what each grasp of that object does, in order: ``ok`` (holds it to
    the end), ``miss`` (the fingers close on nothing) or ``drop`` (holds it, lets it fall once it is lifted)."""

    objects: dict[str, list[float]]
    outcomes: dict[str, list[str]]
    shelf: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """A pedestal at (x, y) with its top at this height (the place spot may be up on one)."""
    arm: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    start: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    target: list[float] = field(default_factory=lambda: [0.3, 0.0, 0.4])
    t0: float = 0.0
    t1: float = 0.0
    command_id: int = 0
    status: str = "idle"
    action: str = "open"
    closed_at: float = 0.0
    held: str | None = None
    grasps: dict[str, int] = field(default_factory=dict)
    carried_moves: list[tuple[float, float, float]] = field(default_factory=list)
    lifted: float | None = None

    def support(self, x: float, y: float, without: str) -> float:
        """Centre height of an object let go at (x, y): on the floor (z = SIZE / 2) or on the stack there."""
        top = self.shelf[2] if math.hypot(self.shelf[0] - x, self.shelf[1] - y) < SIZE else 0.0
        for name, (ox, oy, oz) in self.objects.items():
            if name != without and math.hypot(ox - x, oy - y) < 0.6 * SIZE:
                top = max(top, oz + SIZE / 2)
        return top + SIZE / 2

    def command(self, commands: Any, t: float) -> None:
        arm = commands.get("arm")
        if isinstance(arm, MoveTo):
            self.start, self.target, self.t0 = list(self.arm), list(arm.position), t
            self.t1 = t + max(0.02, math.dist(self.arm, arm.position) / (arm.speed or 1.0))
            self.command_id += 1
            self.status = "moving"
            if self.held is not None:
                self.carried_moves.append(tuple(arm.position))
        elif isinstance(arm, HoldArm):
            self.target, self.t1, self.status = list(self.arm), t, "idle"
            self.command_id += 1
        grip = commands.get("gripper")
        if isinstance(grip, GripperCommand):
            self.action, self.closed_at = grip.action, t
            if grip.action == "close":
                near = [n for n, p in self.objects.items() if math.dist(p, self.arm) < 0.01]
                if near:
                    name = near[0]
                    k = self.grasps.get(name, 0)
                    self.grasps[name] = k + 1
                    plan = self.outcomes[name][min(k, len(self.outcomes[name]) - 1)]
                    if plan != "miss":
                        self.held, self.lifted = name, None
                        self.plan = plan
            else:
                self.let_go()

    def let_go(self) -> None:
        if self.held is not None:
            x, y, _ = self.arm
            self.objects[self.held] = [x, y, self.support(x, y, self.held)]
            self.held = None

    def advance(self, t: float) -> None:
        if self.status == "moving":
            s = min(1.0, (t - self.t0) / (self.t1 - self.t0))
            self.arm = [a + s * (b - a) for a, b in zip(self.start, self.target, strict=True)]
            if s >= 1.0:
                self.status = "reached"
        if self.held is not None:
            self.objects[self.held] = list(self.arm)
            if self.plan == "drop" and self.status == "moving" and self.arm[2] > self.objects_start_z + 0.03:
                self.let_go()

    objects_start_z: float = SIZE / 2

    def readings(self, t: float) -> dict[str, Any]:
        self.advance(t)
        holding = self.held is not None
        width = SIZE if holding else (0.0 if self.action == "close" else 0.08)
        arm = ArmState(tuple(self.arm), DOWN, status=self.status, command_id=self.command_id,  # type: ignore[arg-type]
                       target_position=tuple(self.target), path_end=self.t1 if self.status == "moving" else None)
        grip = GripperState(width=width, target_width=width, action=self.action,
                            settled=t - self.closed_at >= 0.03, holding=holding, held=self.held)
        poses = {n: BodyState(tuple(p), (0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # type: ignore[arg-type]
                 for n, p in self.objects.items()}
        return {"arm": arm, "gripper": grip, "poses": poses}


def pick_place(objects: dict[str, list[float]], place: list[float], **options: Any) -> ScriptedRun:
    config = {"objects": list(objects), "pose_sensor": "poses", "place_position": place, "object_size": SIZE,
              **options}
    return ScriptedRun("pick_place", config, components={"arm": (ArmState, "actuator"),
                                                          "gripper": (GripperState, "actuator"), "poses": dict},
                       bodies=list(objects))


def drive(run: ScriptedRun, world: Tiny, max_time: float, stop_at: float | None = None) -> None:
    commands: Any = {}
    while run.outcome is None and run.t < max_time and (stop_at is None or run.t < stop_at):
        world.command(commands, run.t)
        commands = run.step(world.readings(run.t))


grasp_st = st.lists(st.sampled_from(["ok", "miss", "drop"]), min_size=1, max_size=4)


@settings(max_examples=25, deadline=None)
@given(st.lists(grasp_st, min_size=1, max_size=3), st.integers(1, 4), st.floats(0.025, 0.25))
def test_each_object_reports_the_attempts_the_world_saw(plans: list[list[str]], max_attempts: int,
                                                        place_z: float) -> None:
    objects = {f"cube{i}": [0.45 + 0.08 * i, -0.1, SIZE / 2] for i in range(len(plans))}
    place = [0.4, 0.25, place_z]
    world = Tiny({k: list(v) for k, v in objects.items()}, dict(zip(objects, plans, strict=True)),
                 shelf=(place[0], place[1], place_z - SIZE / 2))
    run = pick_place(objects, place, max_attempts=max_attempts)
    drive(run, world, 60.0)
    result = run.result()
    jobs = result.get("jobs", [result])
    # the oracle: an object takes one attempt per grasp until one holds to the end ("ok"), at most max_attempts
    for name, plan, job in zip(objects, plans, jobs, strict=False):
        wanted = [min(k, len(plan) - 1) for k in range(max_attempts)]
        ok = next((k for k in wanted if plan[k] == "ok"), None)
        assert job["attempts"] == (wanted.index(ok) + 1 if ok is not None else max_attempts), (name, job)
        assert world.grasps.get(name, 0) == job["attempts"]
        if ok is None:
            assert run.outcome.status == "failed"
            break
    else:
        assert run.outcome.status == "succeeded", run.outcome
    # carried, the object flies lift_height above both the pick and the place (the docs' transport altitude)
    lift = 0.08
    for x, y, z in world.carried_moves:
        if math.hypot(x - place[0], y - place[1]) > 1e-6 and z > SIZE:  # a move away from the spot, up high
            assert z >= max(SIZE / 2, place_z) + lift - 1e-9, (z, place_z)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.05, 6.0))
def test_a_halted_pick_place_holds_the_arm_and_keeps_the_grip(at: float) -> None:
    objects = {"cube": [0.5, 0.0, SIZE / 2]}
    world = Tiny({"cube": list(objects["cube"])}, {"cube": ["ok"]})
    run = pick_place(objects, [0.4, 0.25, SIZE / 2])
    drive(run, world, 60.0, stop_at=at)
    held = world.held
    commands = run.behaviour.halt(run.t) or {}
    assert isinstance(commands.get("arm"), HoldArm), commands
    assert "gripper" not in commands or commands["gripper"].action != "open" or held is None


# ---------------------------------------------------------------------------------------------------- patrol
def patrol_config(waypoints: list[list[float]], timeout: float, laps: int = 1) -> dict[str, Any]:
    from robokit.testing import PLANE

    return {
        "world": {"max_time": 60.0},
        "bodies": {"plane": PLANE,
                   "wall": {"shape": "box", "size": [0.2, 2.0, 0.5], "mass": 0, "position": [1.2, 0.0, 0.25]},
                   "post": {"shape": "box", "size": [0.2, 0.2, 0.5], "mass": 0, "position": [-1.0, 1.0, 0.25]}},
        "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 0, 0.06]}},
        "actuators": {"drive": {"type": "diff_drive", "robot": "robot", "rate_hz": 60}},
        "behaviour": {"type": "patrol", "rate_hz": 20, "waypoints": waypoints, "laps": laps, "scan": "",
                      "waypoint_timeout": timeout},
    }


@pytest.mark.parametrize("timeout, laps", [(0.4, 1), (0.25, 2)])
def test_every_leg_gets_its_own_waypoint_timeout(timeout: float, laps: int) -> None:
    """Waypoints far behind a wall cannot be reached in the time allowed: every leg ends missed exactly one
    waypoint_timeout (to the behaviour's step) after the one before it ended."""
    from robokit.testing import make_sim

    waypoints = [[4.0, 0.5], [4.0, -0.5], [3.5, 0.0]]
    with make_sim(patrol_config(waypoints, timeout, laps), seed=0) as sim:
        result = sim.run()
        ends = [r["t"] for r in sim.trace if r["kind"] in ("waypoint_missed", "waypoint_reached")]
    assert result.result["waypoints_missed"] == len(waypoints) * laps == len(ends)
    step = 1.0 / 20
    starts = [0.0, *ends[:-1]]
    for start, end in zip(starts, ends, strict=True):
        assert timeout < end - start <= timeout + step + 1e-6, (start, end)


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(st.lists(st.sets(st.sampled_from(["wall", "post", "plane"])), min_size=1, max_size=25))
def test_each_new_touch_of_a_map_body_is_one_collision(touches: list[set[str]]) -> None:
    from types import SimpleNamespace

    from robokit.testing import make_sim

    with make_sim(patrol_config([[0.5, 0.5]], 5.0), seed=0) as sim:
        patrol = sim.behaviour
        for k, names in enumerate(touches):
            patrol.count_collisions({"drive": SimpleNamespace(contacts=sorted(names))}, k * 0.05)
        counted = [(e["body"], e["t"]) for e in patrol.result()["collision_events"]]
    # the oracle: a touch of a map body (the floor is not one) that was not going on the step before
    expected, before = [], set()
    for k, names in enumerate(touches):
        now = names - {"plane"}
        expected += [(n, round(k * 0.05, 3)) for n in sorted(now - before)]
        before = now
    assert counted == expected


# ---------------------------------------------------------------------------------------------------- sort
class Detector:
    """The sort's colour detector, as the loop serves it: lazy, so a frame is rendered only when read after the
    camera was due again (``rate_hz``); until then a read gives the last frame, stamped with its own time."""

    reading_type = None  # set below (Detections)

    def __init__(self, world: Tiny, colours: dict[str, str], rate_hz: float = 30.0) -> None:
        from robokit_plugins.colour_detector import DEFAULT_COLOURS

        self.world, self.colour_of, self.period = world, colours, 1.0 / rate_hz
        self.colours = {c: DEFAULT_COLOURS[c] for c in ("red", "blue")}
        self.last: Any = None

    def read(self, t: float) -> Any:
        from robokit.msgs.vision import Detection, Detections

        due = self.last is None or math.floor(t / self.period + 1e-9) > math.floor(self.last.time / self.period + 1e-9)
        if due:
            items = tuple(Detection(self.colour_of[n], (0.0, 0.0), 100, (0, 0, 1, 1), tuple(p), tuple(p), 0.0)
                          for n, p in self.world.objects.items() if n != self.world.held)
            self.last = Detections("cam", t, items, ("red", "blue"))
        return self.last


class Lazy(dict):  # type: ignore[type-arg]
    """The readings as the loop serves them: the detector's computed only when the behaviour reads it."""

    def __init__(self, detector: Detector) -> None:
        super().__init__()
        self.detector, self.given, self.t = detector, {}, 0.0

    def __getitem__(self, name: str) -> Any:
        return self.detector.read(self.t) if name == "detector" else self.given[name]

    def get(self, name: str, default: Any = None) -> Any:
        return self[name] if name == "detector" or name in self.given else default

    def __contains__(self, name: object) -> bool:
        return name == "detector" or name in self.given


def sort_run(plans: dict[str, list[str]]) -> tuple[Any, Tiny, dict[str, Any]]:
    """A sort of the scripted cubes (name -> grasp plan) into two bins, stepped at 240 Hz; (sort, world, its
    result)."""
    import numpy as np
    from robokit_behaviours.sort import Sort, SortConfig

    from robokit.checks.scripted import StandIn
    from robokit.components import SetupContext
    from robokit.msgs.vision import Detections
    from robokit.testing import PLANE, make_sim

    Detector.reading_type = Detections
    spots = {name: [0.45 + 0.09 * (i % 3), -0.12 + 0.12 * (i // 3), SIZE / 2] for i, name in enumerate(plans)}
    bodies: dict[str, Any] = {"plane": PLANE}
    for colour, y in (("red", 0.35), ("blue", -0.35)):
        bodies[f"{colour}_bin"] = {"shape": "box", "size": [0.16, 0.16, 0.004], "mass": 0,
                                   "position": [0.35, y, 0.002]}
    for name, spot in spots.items():
        rgba = [0.9, 0.1, 0.1, 1] if name.startswith("red") else [0.1, 0.2, 0.9, 1]
        bodies[name] = {"shape": "box", "size": [SIZE] * 3, "mass": 0.1, "position": spot, "rgba": rgba}
    world = Tiny({n: list(p) for n, p in spots.items()}, dict(plans))
    world.arm = world.start = world.target = [0.28, 0.0, 0.34]
    detector = Detector(world, {n: ("red" if n.startswith("red") else "blue") for n in plans}, rate_hz=1.2)
    sim = make_sim({"bodies": bodies}, seed=0)
    readings = Lazy(detector)
    components = {"detector": detector, "arm": StandIn("arm", ArmState, "actuator"),
                  "gripper": StandIn("gripper", GripperState, "actuator")}
    ctx = SetupContext(sim.world, np.random.default_rng(0), "behaviour", readings, components, ".",
                       lambda kind, **data: None)
    sort = Sort("sort", SortConfig.model_validate({"bins": {"red": {"body": "red_bin"}, "blue": {"body": "blue_bin"}},
                                                   "max_attempts": 3,
                                                   # quick moves: a pick and place well within one camera period
                                                   "pick_place": {"speed": 6.0, "slow_speed": 6.0}}))
    sort.setup(ctx)
    commands: Any = {}
    steps = 0
    try:
        while sort.outcome is None and steps < 240 * 120:
            t = steps / 240.0
            world.command(commands, t)
            readings.given, readings.t = world.readings(t), t
            commands = sort.step(readings, t) or {}
            steps += 1
        result = sort.result()
    finally:
        sim.close()
    return sort, world, result


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sort_counts_every_missed_grasp_and_never_picks_from_an_old_frame(seed: int) -> None:
    import random

    rng = random.Random(seed)
    names = [f"red_{i}" for i in range(rng.randint(1, 2))] + [f"blue_{i}" for i in range(rng.randint(1, 2))]
    plans = {n: [rng.choice(["ok", "miss", "ok"]) for _ in range(2)] + ["ok"] for n in names}
    sort, world, result = sort_run(plans)
    assert sort.outcome is not None and sort.outcome.status == "succeeded", sort.outcome
    # the world's own count: every grasp that did not hold; a grasp where nothing was (a pick from an old frame,
    # at a spot the object has left) would be one more than the plans hold
    missed = sum(plan[:world.grasps.get(n, 0)].count("miss") for n, plan in plans.items())
    assert all(world.grasps.get(n, 0) == plan.index("ok") + 1 for n, plan in plans.items()), world.grasps
    assert result["failures"] == result["misses"]["count"] == missed
    assert result["picks"] == sum(world.grasps.values()) == missed + len(plans)
