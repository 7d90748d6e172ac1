"""A grade is a function of the submission and the seeds: the same submission of the sort assignment (the camera
config whose wall-clock limit once scored 0/4 and 3/4 minutes apart) evaluated on the machine as it is and again
with busy processes on every core gives the same official rows, seed by seed.

    python -m pytest -q -s -n 0 -m slow tests/test_course_grading_load.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import psutil
import pytest
from course_helpers import Course
from course_work import make_assignment, submit

pytest_plugins = ["course_fixtures"]
pytestmark = [pytest.mark.django_db, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[1]
SORT = (ROOT / "configs" / "sort_robot.toml").read_text(encoding="utf-8")
SEEDS = (0, 1, 2, 3)
BUDGET = 4.0
"""CPU seconds per trial: about three times what a sort trial needs (~1.2 s). With a wall-clock limit of 4 s the
loaded run's trials (each waiting its turn among the busy processes) would end aborted."""


@pytest.fixture(autouse=True)
def sync_queue(settings: Any) -> None:
    settings.QUEUE_SYNC = True


def busy(n: int) -> list[subprocess.Popen[bytes]]:
    """``n`` processes that spin forever, each in a session of its own (the kernel's per-session fair share then
    gives each as much CPU as the evaluation's sandbox gets)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True) for _ in range(n)]


def official_rows(sub: Any) -> dict[int, tuple[Any, ...]]:
    return {r.seed: (r.outcome, r.reason, r.sim_time, r.payload["ticks"], r.figures)
            for r in sub.results.all()}


def test_the_same_submission_gets_the_same_rows_on_an_idle_and_a_busy_machine(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, name="분류", seeds=SEEDS, config_text=SORT, allowed_keys=[],
                        trial_seconds=BUDGET)
    t0 = time.monotonic()
    assert submit(client, a.name, SORT, course.kim_token).status_code == 201
    idle_wall = time.monotonic() - t0
    spinners = busy(2 * (os.cpu_count() or 1))
    try:
        procs = [psutil.Process(p.pid) for p in spinners]
        t0 = time.monotonic()
        assert submit(client, a.name, SORT, course.kim_token).status_code == 201
        busy_wall = time.monotonic() - t0
        spun = sum(p.cpu_times().user for p in procs)
    finally:
        for p in spinners:
            p.kill()
            p.wait()
    first, second = Submission.objects.order_by("pk")
    idle, loaded = official_rows(first), official_rows(second)
    assert sorted(idle) == list(SEEDS)
    assert loaded == idle  # outcome, reason, simulated time, ticks and every figure, seed by seed
    assert all(row[0] == "succeeded" and row[4]["success"] == 1 and row[4]["red_sorted"] + row[4]["blue_sorted"] >= 1
               for row in idle.values()), idle
    assert (first.succeeded, first.trials) == (second.succeeded, second.trials) == (len(SEEDS), len(SEEDS))
    print(f"\nas it is: {idle_wall:.1f} s; busy ({len(spinners)} spinning processes took {spun:.0f} CPU s meanwhile): "
          f"{busy_wall:.1f} s (load {os.getloadavg()[0]:.1f})")
    walls = {s: dict(sub.results.values_list("seed", "wall_time")) for s, sub in (("idle", first), ("busy", second))}
    for seed in SEEDS:
        print(f"seed {seed}: {idle[seed][0]}, {idle[seed][3]} ticks, {idle[seed][4]}; trial wall time "
              f"{walls['idle'][seed]:.2f} s idle, {walls['busy'][seed]:.2f} s busy")
