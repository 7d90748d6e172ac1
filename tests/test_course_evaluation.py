"""Official evaluation through the queue library (django-q2, run synchronously here) in the sandbox process: one
official row per seed, the success rate and Wilson interval computed independently, idempotence and resumption,
and the sandbox's limits."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import uuid
from typing import Any

import pytest
from course_helpers import Course
from course_work import OFFICIAL, changed, make_assignment, submit

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
Z = 1.959963984540054


def wilson_low_all_succeeded(n: int) -> float:
    """For n successes out of n the Wilson lower bound is n / (n + z^2) (the interval's closed form at p = 1)."""
    return n / (n + Z * Z)


@pytest.fixture(autouse=True)
def sync_queue(settings: Any) -> None:
    settings.QUEUE_SYNC = True


def test_a_submission_is_evaluated_once_per_official_seed(client: Any, course: Course) -> None:
    from django_q.models import Success

    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(4, 9))
    resp = submit(client, a.name, changed(OFFICIAL, duration="0.3"), course.kim_token)
    assert resp.status_code == 201, resp.content
    sub = Submission.objects.get()
    assert sub.status == "done" and sub.attempts == 1 and sub.error == ""
    rows = list(Result.objects.filter(submission=sub).order_by("seed"))
    assert [r.seed for r in rows] == [4, 9]
    assert all(r.official and r.verified and r.student == course.kim and r.project == a.project for r in rows)
    assert all(r.outcome == "succeeded" and r.reason == "watched 33 bodies for 0.3 s" for r in rows)
    assert [r.run_id for r in rows] == [str(uuid.uuid5(sub.uuid, f"seed={s}")) for s in (4, 9)]
    assert (sub.trials, sub.succeeded, sub.success_rate) == (2, 2, 1.0)
    assert math.isclose(sub.wilson_low, wilson_low_all_succeeded(2)) and math.isclose(sub.wilson_high, 1.0)
    assert Success.objects.count() == 1  # the queue library recorded one finished task


def test_a_failing_config_is_evaluated_with_its_reason(client: Any, course: Course) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0, 1))
    assert submit(client, a.name, changed(OFFICIAL, max_time="0.2"), course.lee_token).status_code == 201
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded, sub.success_rate, sub.wilson_low) == ("done", 2, 0, 0.0, 0.0)
    reasons = set(Result.objects.filter(submission=sub).values_list("outcome", "reason"))
    assert reasons == {("aborted", "max_time 0.2 s reached before the behaviour finished")}


@pytest.mark.slow
def test_evaluating_again_changes_nothing_and_a_partial_evaluation_resumes(client: Any, course: Course,
                                                                          caplog: Any) -> None:
    from robokit.server.evaluation import evaluate_submission
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0, 1, 2))
    submit(client, a.name, OFFICIAL, course.kim_token)
    sub = Submission.objects.get()
    kept = {r.seed: r.pk for r in sub.results.all()}
    assert evaluate_submission(sub.pk) == "nothing to do"  # the task delivered twice
    assert Result.objects.count() == 3
    # A worker killed after seed 1 was stored: seed 2 missing, the submission still running.
    Result.objects.filter(submission=sub, seed=2).delete()
    Submission.objects.filter(pk=sub.pk).update(status="running", trials=0, succeeded=0, success_rate=None)
    with caplog.at_level("INFO", logger="robokit.server.evaluation"):
        assert evaluate_submission(sub.pk) == "done"
    assert not [r for r in caplog.records if "already stored" in r.getMessage()]  # seeds 0 and 1 never ran again
    sub.refresh_from_db()
    assert sub.attempts == 2 and sub.status == "done" and sub.trials == 3
    now = {r.seed: r.pk for r in sub.results.all()}
    assert now[0] == kept[0] and now[1] == kept[1] and now[2] != kept[2]  # only the missing trial ran again


@pytest.mark.slow
def test_a_trial_over_its_cpu_budget_ends_aborted(client: Any, course: Course) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0,), trial_seconds=0.5)
    # An hour of sim time: no machine steps 33 bodies 7,200x faster than real time on 0.5 s of processor time.
    hour = changed(OFFICIAL, duration="3600.0", max_time="3700.0")
    assert submit(client, a.name, hour, course.kim_token).status_code == 201
    sub = Submission.objects.get()
    row = Result.objects.get(submission=sub)
    assert row.outcome == "aborted", row.reason
    assert row.reason.startswith("interrupted by its CPU-time budget (0.5 s of processor time) at t = "), row.reason
    assert 0 < row.sim_time < 3600 and sub.status == "done" and sub.success_rate == 0.0


def test_a_submitted_wall_clock_budget_is_set_aside(client: Any, course: Course) -> None:
    """``world.max_wall_time`` would make the grade depend on the machine's load: the official trial ignores it."""
    from robokit.server.models import Result

    a = make_assignment(course.room, seeds=(0,), allowed_keys=["world.*", "behaviour.duration"])
    text = OFFICIAL.replace("[world]", "[world]\nmax_wall_time = 0.001", 1)
    assert "max_wall_time = 0.001" in text
    assert submit(client, a.name, text, course.kim_token).status_code == 201
    row = Result.objects.get()
    assert (row.outcome, row.reason) == ("succeeded", "watched 33 bodies for 0.5 s")


def test_a_trial_past_the_wall_clock_safety_net_is_requeued_not_graded(client: Any, course: Course,
                                                                       monkeypatch: Any) -> None:
    from robokit.server import sandbox
    from robokit.server.evaluation import evaluate_submission
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0, 1))
    monkeypatch.setattr(sandbox, "WALL_FACTOR", 0.0)
    monkeypatch.setattr(sandbox, "WALL_MARGIN", 0.05)  # no process starts this fast: the net trips
    assert submit(client, a.name, OFFICIAL, course.kim_token).status_code == 201
    sub = Submission.objects.get()
    assert Result.objects.count() == 0  # nothing graded
    assert (sub.status, sub.requeued, sub.attempts) == ("queued", 1, 1)
    assert re.fullmatch(r"re-queued at \d\d:\d\d UTC: a trial ran past the wall-clock safety limit \(0\.05 s\)"
                        r" - the machine was too busy or the trial waited on something", sub.note), sub.note
    monkeypatch.undo()
    assert evaluate_submission(sub.pk) == "done"  # the queue's next delivery
    sub.refresh_from_db()
    assert (sub.status, sub.trials, sub.succeeded, sub.attempts) == ("done", 2, 2, 2)
    assert sorted(Result.objects.values_list("seed", flat=True)) == [0, 1]


def test_the_sandbox_sets_its_limits_before_anything_runs() -> None:
    code = ("import json, resource, sys; from robokit.server.sandbox import apply_limits; "
            "apply_limits({'cpu': 42, 'memory_mb': 1500, 'file': 1 << 20}); "
            "print(json.dumps([resource.getrlimit(r) for r in (resource.RLIMIT_CPU, resource.RLIMIT_AS, "
            "resource.RLIMIT_FSIZE, resource.RLIMIT_CORE)])); "
            "open('big', 'wb').write(b'x' * (2 << 20))")
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=scratch, timeout=60)
    limits = json.loads(proc.stdout.splitlines()[0])
    assert limits == [[42, 42], [1500 << 20, 1500 << 20], [1 << 20, 1 << 20], [0, 0]]
    assert proc.returncode != 0  # writing past the file-size limit kills it (SIGXFSZ) or fails (EFBIG)


def test_the_sandbox_has_no_network_where_the_machine_allows_it() -> None:
    import socket

    from robokit.server.sandbox import network_isolation, sandbox_command

    if not network_isolation():
        pytest.skip("no unprivileged network namespaces here: the sandbox has the server's network (documented)")
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        port = listener.getsockname()[1]
        probe = f"import socket; socket.create_connection(('127.0.0.1', {port}), timeout=5)"
        outside = subprocess.run([sys.executable, "-c", probe], capture_output=True, timeout=60)
        inside = subprocess.run([*sandbox_command()[:-2], "-c", probe], capture_output=True, timeout=60)
    assert outside.returncode == 0  # the listener is reachable from the server's own network
    assert inside.returncode != 0 and b"Network is unreachable" in inside.stderr
