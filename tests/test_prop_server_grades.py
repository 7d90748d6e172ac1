"""A graded submission's success rate against its per-trial flags, everywhere the server shows both.

An evaluated submission derives its figures twice: each official trial is stored as a result with its outcome and a
``success`` flag, and the submission carries the rate, the count and the Wilson bounds summarised from them. Here the
trials' outcomes are generated (one per official seed, a worker storing one twice, the summary asked for twice) and
every place that shows them is read back -- the submission's API answer, its trials there, the grades CSV -- and each
figure recomputed here from the generated outcomes: counts by counting, the Wilson bounds as the roots of the score
equation.
"""

from __future__ import annotations

import csv
import io
import itertools
from typing import Any

import numpy as np
import pytest
from course_helpers import PASSWORD
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=5, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])
Z = 1.959963984540054
OUTCOMES = ("succeeded", "failed", "aborted", "error")
_ids = itertools.count(1)


def score_roots(k: int, n: int) -> tuple[float, float]:
    """Wilson's interval: the p where (k/n - p)^2 = z^2 p (1 - p) / n, the roots of that quadratic in p."""
    phat = k / n
    roots = np.roots([1 + Z * Z / n, -(2 * phat + Z * Z / n), phat * phat]).real
    return float(min(roots)), float(max(roots))


@pytest.fixture
def teacher_client(client: Any, course: Any) -> Any:
    assert client.login(username="teacher", password=PASSWORD)
    return client


@PROPS
@given(st.lists(st.sampled_from(OUTCOMES), min_size=1, max_size=6), st.data())
def test_a_submissions_rate_is_its_trials_flags_on_every_page(teacher_client: Any, course: Any, outcomes: list[str],
                                                               data: Any) -> None:
    from course_work import OFFICIAL, make_assignment

    from robokit.server.evaluation import finish, store_trial
    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.filter(name="낙하 실험").delete()
    seeds = list(range(10, 10 + len(outcomes)))
    assignment = make_assignment(course.room, seeds=tuple(seeds))
    sub = Submission.objects.create(assignment=assignment, student=course.kim, config_text=OFFICIAL)
    again = data.draw(st.sampled_from(seeds))  # a worker that stores one trial twice
    rows = [{"run_id": f"00000000-0000-4000-9000-{next(_ids):012d}", "key": f"official/{seed}", "seed": seed,
             "outcome": o, "reason": "" if o == "succeeded" else f"{o} on seed {seed}", "sim_time": 0.5,
             "wall_time": 0.1, "figures": {"drop_m": 0.1 * seed}, "result": {"behaviour": "drop_test"}}
            for seed, o in zip(seeds, outcomes, strict=True)]
    for row in rows + [r for r in rows if r["seed"] == again]:
        store_trial(sub, row)
    assert finish(sub) == "done" and finish(sub) == "already done"

    n, k = len(outcomes), outcomes.count("succeeded")
    low, high = score_roots(k, n)
    answer = teacher_client.get(f"/api/robotics/submissions/{sub.pk}/",
                                HTTP_AUTHORIZATION=f"Bearer {course.kim_token}").json()
    assert (answer["status"], answer["succeeded"], answer["seeds"]) == ("done", k, n)
    assert answer["success_rate"] == pytest.approx(k / n, abs=1e-12)
    assert answer["wilson95"] == pytest.approx([low, high], abs=1e-9)
    # each trial once, seed by seed, its outcome and its success flag as generated
    assert [(t["seed"], t["outcome"], t["figures"]["success"], t["reason"]) for t in answer["trials"]] == [
        (r["seed"], r["outcome"], int(r["outcome"] == "succeeded"), r["reason"]) for r in rows]
    assert sum(t["figures"]["success"] for t in answer["trials"]) == answer["succeeded"]

    grades = teacher_client.get(f"/classes/{course.room.pk}/grades.csv")
    table = list(csv.reader(io.StringIO(grades.content.decode("utf-8-sig"))))
    head, mine = table[0], next(r for r in table[1:] if r[0] == course.kim.name)
    got = dict(zip(head, mine, strict=True))
    col = f"{assignment.name}: "
    assert got[col + "success_rate"] == f"{k / n:.4f}"
    assert got[col + "wilson_low"] == f"{low:.4f}" and got[col + "wilson_high"] == f"{high:.4f}"
    assert (got[col + "submissions"], got[col + "late"]) == ("1", "")
    other = next(r for r in table[1:] if r[0] != course.kim.name)  # a student with no submission: empty cells
    assert dict(zip(head, other, strict=True))[col + "success_rate"] == ""
