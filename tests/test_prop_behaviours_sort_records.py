"""sort's every result field, reason and decision against a scripted table (no physics): cubes at generated places,
colours (one with no bin) and grasp plans (each grasp holds, closes on nothing, or lets the cube fall once lifted);
an arm that goes straight to its targets; a lazy detector that renders a frame only when read after it was due again,
with a frame from before the sort began still in its cache. The oracles are the table's own record: which cube each
grasp was at, where the cubes lie at the end (in which bin, on which slot), what the arm's position was when the frame
each decision read was rendered; the run's transition records for times; plain counts written here. docs/vision.md
("sort behaviour") is the promise: counts per colour in the world, failures per failed attempt, one record per
object, the nearest object first, a fresh frame per look taken with the arm out of view, the next free slot of the
bin, the reasons."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from robokit.checks.scripted import StandIn
from robokit.components import SetupContext
from robokit.msgs.arm import ArmState, GripperState
from robokit.msgs.vision import Detection, Detections

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_prop_sample_behaviours import SIZE, Tiny  # noqa: E402  (the scripted arm, fingers and cubes)

RGBA = {"red": (0.9, 0.1, 0.1, 1.0), "blue": (0.1, 0.2, 0.9, 1.0), "green": (0.1, 0.8, 0.1, 1.0),
        "grey": (0.5, 0.5, 0.5, 1.0)}
CLASSES = ("red", "blue", "green")  # the detector's colour classes: grey matches none
BINS = {"red": (0.35, 0.42), "blue": (0.35, -0.42)}  # bin centres (x, y); 0.16 m square, rim 5 cm high
HALF, RIM = 0.08, 0.05
LOOK = (0.28, 0.0, 0.34)  # the sort's default look_position
SPOTS = [(0.42, -0.17), (0.42, 0.0), (0.42, 0.17), (0.6, -0.17), (0.6, 0.0), (0.6, 0.17)]  # 17 cm apart at least
SLOT = 0.07 / 2  # BinConfig's slot_spacing, halved
RATE = 240.0


class Table:
    """The World as the sort sees it, answered from the scripted cell: body names, colours, masses, the bins' and
    cubes' poses and boxes."""

    def __init__(self, cell: Tiny, colours: dict[str, str]) -> None:
        self.cell, self.colours, self.tick = cell, colours, 0
        self.removed: set[str] = set()

    @property
    def body_names(self) -> list[str]:
        return [*(f"{c}_bin" for c in BINS), *(n for n in self.colours if n not in self.removed)]

    def has_body(self, name: str) -> bool:
        return name in self.body_names

    def body(self, name: str) -> str:
        return name

    def joints(self, body: str) -> list[Any]:
        return []

    def mass(self, body: str) -> float:
        return 0.0 if body.endswith("_bin") else 0.1

    def visual_rgba(self, body: str) -> tuple[float, ...]:
        return RGBA[self.colours[body]] if body in self.colours else (0.3, 0.3, 0.3, 1.0)

    def pose(self, name: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        if name.endswith("_bin"):
            x, y = BINS[name[:-4]]
            return (x, y, 0.0), (0.0, 0.0, 0.0, 1.0)
        return tuple(self.cell.objects[name]), (0.0, 0.0, 0.0, 1.0)

    def body_aabb(self, name: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        (x, y, z), _ = self.pose(name)
        if name.endswith("_bin"):
            return (x - HALF, y - HALF, z - RIM), (x + HALF, y + HALF, z + RIM)
        return (x - SIZE / 2, y - SIZE / 2, z - SIZE / 2), (x + SIZE / 2, y + SIZE / 2, z + SIZE / 2)


class Camera:
    """The detector, lazy: a frame is rendered when read after the camera was due again (``period``); each
    rendering is noted with where the arm was and what lay on the table."""

    reading_type = Detections

    def __init__(self, cell: Tiny, colours: dict[str, str], period: float) -> None:
        from robokit_plugins.colour_detector import DEFAULT_COLOURS

        self.cell, self.colour_of, self.period = cell, colours, period
        self.colours = {c: DEFAULT_COLOURS[c] for c in CLASSES}
        self.hidden: set[str] = set()  # cubes the camera cannot see (under the arm's shadow, say)
        self.offset: dict[str, tuple[float, float]] = {}  # how far off (x, y) each cube is detected, m
        self.cfg = SimpleNamespace(camera="cam")
        self.last: Detections | None = None
        self.renders: list[tuple[float, tuple[float, ...], dict[str, tuple[float, ...]]]] = []

    def read(self, t: float) -> Detections:
        last = self.last
        if last is None or math.floor(t / self.period + 1e-9) > math.floor(last.time / self.period + 1e-9):
            seen = {n: tuple(p) for n, p in self.cell.objects.items()
                    if n != self.cell.held and n not in self.hidden and self.colour_of[n] in CLASSES}
            off = {n: self.offset.get(n, (0.0, 0.0)) for n in seen}
            at = {n: (p[0] + off[n][0], p[1] + off[n][1], p[2]) for n, p in seen.items()}
            items = tuple(Detection(self.colour_of[n], (0.0, 0.0), 300, (0, 0, 1, 1), at[n], at[n], 0.0)
                          for n in seen)
            self.last = Detections("cam", t, items, CLASSES)
            self.renders.append((t, tuple(self.cell.arm), seen))
        assert self.last is not None
        return self.last


class Readings(dict):  # type: ignore[type-arg]
    """The loop's readings: the detector's computed when read; ``computed`` counts the camera's renders."""

    def __init__(self, camera: Camera) -> None:
        super().__init__()
        self.camera, self.given, self.t = camera, {}, 0.0

    def __getitem__(self, name: str) -> Any:
        return self.camera.read(self.t) if name == "detector" else self.given[name]

    def get(self, name: str, default: Any = None) -> Any:
        return self[name] if name == "detector" or name in self.given else default

    def __contains__(self, name: object) -> bool:
        return name == "detector" or name in self.given

    def computed(self, name: str) -> int:
        assert name == "cam"
        return len(self.camera.renders)


class Run:
    """One sort on the scripted table, begun at ``t0`` (the frame in the camera's cache is from before ``t0``)."""

    def __init__(self, cubes: dict[str, tuple[str, tuple[float, float], list[str]]], *, t0: float = 0.0,
                 max_attempts: int = 3, max_picks: int = 30, period: float = 1 / 1.2,
                 arm: tuple[float, float, float] = LOOK, truth: bool = False) -> None:
        from robokit_behaviours.sort import Sort, SortConfig

        self.colours = {n: c for n, (c, _, _) in cubes.items()}
        self.start = {n: (x, y, SIZE / 2) for n, (_, (x, y), _) in cubes.items()}
        self.cell = Tiny({n: list(p) for n, p in self.start.items()}, {n: plan for n, (_, _, plan) in cubes.items()})
        self.cell.arm, self.cell.start, self.cell.target = list(arm), list(arm), list(arm)
        self.camera = Camera(self.cell, self.colours, period)
        self.table = Table(self.cell, self.colours)
        self.readings = Readings(self.camera)
        self.trace: list[dict[str, Any]] = []
        self.t0 = t0
        if t0 > 0:  # a frame of the table as it was 0.3 s before, in t0's camera period: the cubes 6 cm aside
            for name in self.cell.objects:
                self.cell.objects[name][1] += 0.06
            self.readings.t = t0 - 0.3
            self.camera.read(t0 - 0.3)
            for name, p in self.start.items():
                self.cell.objects[name] = list(p)
        components = {"detector": self.camera, "cam": StandIn("cam", object, "sensor"),
                      "arm": StandIn("arm", ArmState, "actuator"),
                      "gripper": StandIn("gripper", GripperState, "actuator"),
                      **({"poses": StandIn("poses", dict, "sensor")} if truth else {})}  # the table's cube poses
        ctx = SetupContext(self.table, np.random.default_rng(0), "behaviour", self.readings,  # type: ignore[arg-type]
                           components, Path("."), self._note)
        self.max_attempts = max_attempts
        self.sort = Sort("sort", SortConfig.model_validate({
            "bins": {c: {"body": f"{c}_bin"} for c in BINS}, "max_attempts": max_attempts, "max_picks": max_picks,
            "pick_place": {"speed": 6.0, "slow_speed": 6.0}, "truth_sensor": "poses" if truth else None}))
        self.sort.setup(ctx)
        self.decisions: list[tuple[int, tuple[float, ...], Any, dict[str, int]]] = []
        """Per look: the frame it read (render index), the arm's reading, the pick it started, the grasps so far."""
        self.t = t0

    def _note(self, kind: str, **data: Any) -> None:
        self.trace.append({"t": round(self.t, 6), "kind": kind, **data})

    def play(self, until: float = 120.0) -> None:
        commands: Any = {}
        sort = self.sort
        while sort.outcome is None and self.t < until - 1e-9:
            self.cell.command(commands, self.t)
            self.readings.given, self.readings.t = self.cell.readings(self.t), self.t
            self.table.tick = round(self.t * RATE)
            looks, arm = sort.looks, self.readings.given["arm"].position
            commands = sort.step(self.readings, self.t) or {}
            if sort.looks > looks:
                task = sort.pp.task if sort.state_name == "PICK_PLACE" else None
                self.decisions.append((len(self.camera.renders) - 1, arm, task, dict(self.cell.grasps)))
            self.t += 1 / RATE


def out_of_view(arm: tuple[float, ...]) -> bool:
    """At the look position, or over a bin (where a place leaves the arm)."""
    return math.dist(arm, LOOK) < 0.01 or any(abs(arm[0] - x) <= HALF and abs(arm[1] - y) <= HALF
                                              for x, y in BINS.values())


def in_bin(p: list[float] | tuple[float, ...], colour: str) -> bool:
    x, y = BINS[colour]
    return abs(p[0] - x) <= HALF and abs(p[1] - y) <= HALF and p[2] < RIM


REASONS = {"miss": "grasp failed: fingers closed to 0.0 mm without holding (after 1 attempt)",
           "drop": "dropped during LIFT (after 1 attempt)"}

cubes_st = st.lists(st.tuples(st.sampled_from(["red", "red", "blue", "green"]),
                              st.lists(st.sampled_from(["ok", "miss", "drop"]), min_size=1, max_size=3)),
                    min_size=1, max_size=5)


@settings(max_examples=8, deadline=None, derandomize=True)
@example([("red", ["ok"]), ("red", ["miss"]), ("red", ["miss", "ok"])], [0, 2, 3, 1, 4, 5], 3, 0.0,
         LOOK)  # six red picks: the sixth places on a slot the first left free
@given(cubes_st, st.permutations(range(len(SPOTS))), st.integers(1, 3), st.sampled_from([0.0, 2.9]),
       st.sampled_from([LOOK, (0.5, 0.05, 0.22)]))  # the arm starts out of the camera's view, or over the table
def test_every_figure_of_a_sort_against_the_tables_record(cubes: list[tuple[str, list[str]]], spots: list[int],
                                                          max_attempts: int, t0: float,
                                                          arm: tuple[float, float, float]) -> None:
    plan = {f"{colour}_{i}": (colour, SPOTS[spots[i]], grasps) for i, (colour, grasps) in enumerate(cubes)}
    run = Run(plan, t0=t0, max_attempts=max_attempts, arm=arm)
    run.play()
    sort, cell = run.sort, run.cell
    assert sort.outcome is not None, "the sort ended"
    result = sort.result()
    # each cube is grasped until a grasp holds to the bin, at most max_attempts times; green cubes never
    tried = {n: [g[min(k, len(g) - 1)] for k in range(max_attempts)] for n, (c, _, g) in plan.items() if c != "green"}
    attempts = {n: tries.index("ok") + 1 if "ok" in tries else max_attempts for n, tries in tried.items()}
    failures = {n: [REASONS[g] for g in tries[:attempts[n]] if g != "ok"] for n, tries in tried.items()}
    assert {n: cell.grasps.get(n, 0) for n in attempts} == attempts
    assert result["picks"] == sum(attempts.values()) and result["looks"] == result["picks"] + 1
    failed = sum(len(f) for f in failures.values())
    assert result["failures"] == result["misses"]["count"] == failed
    order = list(cell.grasps)  # the cubes in the order of their first grasp
    assert result["misses"]["reasons"] == [f"{n}: {why}" for n in order for why in failures[n]]
    # one record per cube picked, in that order, then the cubes of a colour with no bin, left where they lie
    sorted_ = [n for n in order if "ok" in tried[n]]
    records = result["objects"]
    picked = records[:len(order)]
    assert [(r["colour"], r["bin"], r["attempts"]) for r in picked] == [
        (plan[n][0], f"{plan[n][0]}_bin", attempts[n]) for n in order]
    for r, n in zip(picked, order, strict=True):
        assert r["body"] == n and r["detected_position"] == [round(v, 4) for v in run.start[n]]
        assert (r["outcome"], r["reason"]) == (("sorted", "") if n in sorted_ else ("failed", failures[n][-1]))
    greens = sorted(n for n in plan if plan[n][0] == "green")
    left = sorted(records[len(order):], key=lambda r: r["detected_position"])
    assert [(r["colour"], r["outcome"], r["reason"]) for r in left] == [("green", "left", "no bin for green")] * len(
        greens)
    assert [r["detected_position"] for r in left] == sorted([round(v, 4) for v in run.start[n]] for n in greens)
    assert all(cell.objects[n] == list(run.start[n]) for n in greens), "a cube of a colour with no bin was moved"
    # the per-colour counts are the cubes the table has inside their colour's bin, every colour class of the
    # detector named (green, with no bin: 0)
    there = {c: sum(in_bin(cell.objects[n], c) for n in plan if plan[n][0] == c) for c in BINS}
    assert {k: v for k, v in result.items() if k.endswith("_sorted")} == {
        "red_sorted": there["red"], "blue_sorted": there["blue"], "green_sorted": 0}
    assert there["red"] + there["blue"] == len(sorted_), "every cube placed lies in its bin"
    for colour in BINS:  # on a slot of its own
        slots = [tuple(round(v, 6) for v in cell.objects[n][:2]) for n in sorted_ if plan[n][0] == colour]
        assert len(set(slots)) == len(slots), f"two {colour} cubes on one slot: {slots}"
    # the outcome and its reason
    assert sort.outcome.status == ("failed" if len(sorted_) < len(order) else "succeeded")
    tail = f"; left {len(greens)} whose colour has no bin (green)" if greens else ""
    assert sort.outcome.reason == f"sorted {len(sorted_)} object(s) in {result['picks']} pick(s){tail}"
    # times: the sort's own, from its first step to its last transition; each cube's pick-and-place jobs summed
    ends = [r["t"] for r in run.trace if r["kind"] == "transition" and r["machine"] == "sort"]
    assert abs(result["total_time"] - (ends[-1] - t0)) < 1e-3
    jobs, begun = [], 0.0
    for r in run.trace:
        if r["kind"] == "transition" and r["machine"] == "pick_place":
            if r["trigger"] == "begin":
                begun = r["t"]
            elif r["dest_state"] in ("DONE", "FAILED"):
                jobs.append(r["t"] - begun)
    picks = [d for d in run.decisions if d[2] is not None]
    assert len(jobs) == len(picks) == result["picks"]
    spent = dict.fromkeys(order, 0.0)
    for (index, _, task, _), seconds in zip(picks, jobs, strict=True):
        table = run.camera.renders[index][2]
        spent[next(n for n, p in table.items() if p == tuple(task.pick_position))] += seconds
    assert [r["pick_place_time"] for r in picked] == [round(spent[n], 4) for n in order]
    # every look decided on a fresh frame: rendered after the sort began, with the arm out of the camera's view
    assert result["camera_frames"] == sum(t >= t0 - 1e-9 for t, _, _ in run.camera.renders)
    for index, arm, task, grasps in run.decisions:
        at, arm_then, table = run.camera.renders[index]
        assert at >= t0 - 1e-9 and out_of_view(arm_then), (at, arm_then)
        if task is None:
            continue
        # the cube chosen is the sortable one nearest the gripper (xy) where the table had it in that frame: not in
        # its bin, not given up (all its attempts used without a success)
        gave_up = {n for n in order if grasps.get(n, 0) >= attempts[n] and n not in sorted_}
        candidates = [n for n in table if plan[n][0] in BINS and not in_bin(table[n], plan[n][0])
                      and n not in gave_up]
        nearest = min(math.dist(arm[:2], table[n][:2]) for n in candidates)
        assert abs(math.dist(arm[:2], task.pick_position[:2]) - nearest) < 1e-9


@settings(max_examples=8, deadline=None, derandomize=True)
@given(st.integers(1, 6), st.integers(1, 3))
def test_max_picks_ends_the_sort_saying_how_many_sortable_cubes_it_still_saw(max_picks: int, cubes: int) -> None:
    """Cubes whose every grasp misses: the sort picks exactly max_picks times (the table's grasps), then fails
    naming the picks and the sortable cubes its last look saw (those not given up: the table's count)."""
    plan = {f"red_{i}": ("red", SPOTS[2 * i], ["miss"]) for i in range(cubes)}
    run = Run(plan, max_attempts=2, max_picks=max_picks)
    run.play()
    grasps = sum(run.cell.grasps.values())
    result = run.sort.result()
    given_up = sum(g >= 2 for g in run.cell.grasps.values())
    assert run.sort.outcome is not None and run.sort.outcome.status == "failed"
    if given_up == cubes:  # every cube given up: the last look saw nothing sortable
        assert grasps <= max_picks and run.sort.outcome.reason == f"sorted 0 object(s) in {grasps} pick(s)"
    else:
        assert grasps == max_picks
        assert run.sort.outcome.reason == f"{max_picks} pick attempts used up; {cubes - given_up} sortable " \
                                          "object(s) remain"
    assert result["picks"] == grasps and result["failures"] == grasps and result["looks"] == grasps + 1
    # every cube tried is reported failed at the end, one given up or one still waiting for its next attempt
    assert [(r["outcome"], r["attempts"]) for r in result["objects"]] == [
        ("failed", run.cell.grasps[n]) for n in run.cell.grasps]


@settings(max_examples=10, deadline=None, derandomize=True)
@given(st.floats(0.05, 3.0), st.sampled_from(["ok", "miss", "drop"]))
def test_a_halted_sort_leaves_the_arm_where_it_was_and_the_cube_in_the_fingers(at: float, grasp: str) -> None:
    """Halted at any moment (a composite's timeout, a monitor): what its halt commands, given to the table, keeps
    the arm where it was and a cube between the fingers there, for a second of the table's time."""
    run = Run({"red_0": ("red", SPOTS[1], [grasp, "ok"]), "blue_1": ("blue", SPOTS[5], ["ok"])})
    run.play(until=at)
    if run.sort.outcome is not None:
        return
    cell = run.cell
    cell.command(run.sort.halt(run.t) or {}, run.t)
    arm, held = list(cell.arm), cell.held
    for k in range(1, 241):
        cell.readings(run.t + k / 240)
    assert cell.arm == arm, f"the arm went on from {arm} to {cell.arm} after the halt"
    assert cell.held == held and (held is None or cell.objects[held] == arm), "the fingers let go"


def test_a_look_that_gets_no_fresh_frame_times_out_saying_so() -> None:
    """The camera's cached frame is from before the sort began and the camera is not due again for a minute: LOOK
    waits for a fresh frame until its 1 s timeout, and the sort fails saying so, having looked at nothing."""
    run = Run({"red_0": ("red", SPOTS[0], ["ok"])}, t0=30.5, period=60.0)
    run.play(until=40.0)
    assert run.sort.outcome is not None
    assert (run.sort.outcome.status, run.sort.outcome.reason) == ("failed",
                                                                  "timed out in state LOOK after 1 s (sim time)")
    result = run.sort.result()
    assert result["looks"] == result["picks"] == 0 and run.cell.grasps == {}
    assert result["camera_frames"] == 0 and abs(result["total_time"] - 1.0) <= 2 / RATE


def test_cubes_over_a_bin_or_within_its_margin_are_left_where_they_lie() -> None:
    """docs/vision.md: detections over a bin, its footprint grown by bin_margin (2 cm), are ignored: a red cube on the
    blue bin's edge and one 1.5 cm beyond it stay; one 3 cm beyond it is sorted into the red bin."""
    x, y = BINS["blue"]
    edge, near, far = (x + HALF, y), (x + HALF + 0.015, y + 0.1), (x + HALF + 0.03, y + 0.2)
    run = Run({"red_0": ("red", edge, ["ok"]), "red_1": ("red", near, ["ok"]), "red_2": ("red", far, ["ok"])})
    run.play()
    assert run.sort.outcome is not None and run.sort.outcome.status == "succeeded"
    assert list(run.cell.grasps) == ["red_2"] and in_bin(run.cell.objects["red_2"], "red")
    assert run.cell.objects["red_0"] == list(run.start["red_0"]) and run.cell.objects["red_1"] == list(
        run.start["red_1"])
    assert run.sort.result()["red_sorted"] == 1 and len(run.sort.result()["objects"]) == 1


@settings(max_examples=6, deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.floats(-0.006, 0.006), st.floats(-0.006, 0.006)), min_size=1, max_size=4))
def test_with_a_truth_sensor_each_record_names_its_cube_and_how_far_off_it_was_detected(
        offsets: list[tuple[float, float]]) -> None:
    """docs/vision.md: ``truth_sensor`` is read for the report only: each object's record names the body nearest
    to where it was detected and the detection error, the distance the test put between the two."""
    plan = {f"{'red' if i % 2 else 'blue'}_{i}": ("red" if i % 2 else "blue", SPOTS[i], ["ok"])
            for i in range(len(offsets))}
    run = Run(plan, truth=True)
    run.camera.offset = dict(zip(plan, offsets, strict=True))
    run.play()
    records = {r["body"]: r for r in run.sort.result()["objects"]}
    assert set(records) == set(plan) and run.sort.outcome is not None and run.sort.outcome.status == "succeeded"
    for name, (dx, dy) in zip(plan, offsets, strict=True):
        x, y, z = run.start[name]
        assert records[name]["detected_position"] == [round(x + dx, 4), round(y + dy, 4), round(z, 4)]
        assert records[name]["detection_error"] == round(math.hypot(dx, dy), 5)
