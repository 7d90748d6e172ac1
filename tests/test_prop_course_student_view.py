"""What a student sees of their own submissions, over generated submissions of two students (docs/server.md, "What a
student sees").

The student's page (``/me/``, opened with their token) lists their submissions, each with its state and grade and,
once evaluated, every official trial: seed, outcome, reason. The API gives the same to that student's token; to
anyone else's token the submission does not exist (404). Students never see each other's trials.

Each example stores submissions of two students in generated states, the evaluated ones with generated trial outcomes
(stored as a worker stores them, then summarised); each reason names its owner and seed. Expected: per student,
their submissions newest first, counted here from what was generated, with their trials by seed, and nothing of the
other's anywhere on their page or in their API answers.
"""

from __future__ import annotations

import datetime as dt
import html
import itertools
import re
from typing import Any

from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=6, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
SEEDS = (4, 7, 9)
_ids = itertools.count(1)
work = st.lists(st.tuples(st.sampled_from(["kim", "lee"]), st.sampled_from(["queued", "running", "done", "error"]),
                          st.lists(st.sampled_from(["succeeded", "failed", "aborted"]), min_size=3, max_size=3)),
                max_size=5)


@PROPS
@given(work)
def test_each_student_sees_their_own_submissions_and_trials_and_nothing_else(client: Any, course: Any,
                                                                             drawn: list[Any]) -> None:
    from course_work import OFFICIAL, make_assignment
    from django.test import Client

    from robokit.server.evaluation import finish, store_trial
    from robokit.server.models import Assignment, Project, Submission

    Assignment.objects.all().delete()
    Project.objects.all().delete()
    a = make_assignment(course.room, seeds=SEEDS)
    who = {"kim": (course.kim, course.kim_token), "lee": (course.lee, course.lee_token)}
    made: dict[str, list[dict[str, Any]]] = {"kim": [], "lee": []}
    start = dt.datetime(2026, 11, 20, 9, 0, tzinfo=dt.timezone.utc)
    for i, (name, status, outcomes) in enumerate(drawn):
        student = who[name][0]
        sub = Submission.objects.create(assignment=a, student=student, config_text=OFFICIAL)
        Submission.objects.filter(pk=sub.pk).update(submitted_at=start + dt.timedelta(minutes=i))
        trials = []
        if status == "done":
            for seed, outcome in zip(SEEDS, outcomes, strict=True):
                reason = "" if outcome == "succeeded" else f"{name} {sub.pk} seed {seed} {outcome}"
                store_trial(sub, {"run_id": f"00000000-0000-4000-a000-{next(_ids):012d}", "key": f"seed={seed}",
                                  "seed": seed, "outcome": outcome, "reason": reason, "sim_time": 0.5,
                                  "figures": {}, "result": {}})
                trials.append((seed, outcome, reason))
            assert finish(sub) == "done"
        else:
            Submission.objects.filter(pk=sub.pk).update(status=status)
        made[name].append({"pk": sub.pk, "status": status, "trials": trials,
                           "ok": sum(o == "succeeded" for _, o, _ in trials)})

    for name, (_student, token) in who.items():
        other = "lee" if name == "kim" else "kim"
        browser = Client()
        assert browser.post("/me/", {"token": token}).status_code == 302
        page = browser.get("/me/").content.decode()
        mine = list(reversed(made[name]))  # newest first
        if not mine:
            assert 'id="my-submissions"' not in page
        else:
            table = page.split('id="my-submissions"')[1]
            rows = re.findall(r'<tr id="submission-(\d+)"><td>[^<]*</td><td>[^<]*</td><td>(\w+)', table)
            assert [(int(pk), state) for pk, state in rows] == [(m["pk"], m["status"]) for m in mine]
            for m in mine:
                block = table.split(f'id="submission-{m["pk"]}"')[1].split('<tr id="submission-')[0]
                if m["status"] == "done":
                    assert f"{m['ok']}/{len(SEEDS)} (" in block
                seeds = [(int(s), o, html.unescape(r)) for s, o, r in re.findall(
                    r'<tr><td>(\d+)</td><td class="outcome \w+">(\w+)</td><td>([^<]*)</td>', block)]
                assert seeds == m["trials"]
        for m in made[other]:
            assert f'id="submission-{m["pk"]}"' not in page
            assert all(r not in page for _, _, r in m["trials"] if r)
        for m in made[name] + made[other]:
            answer = client.get(f"/api/robotics/submissions/{m['pk']}/", HTTP_AUTHORIZATION=f"Bearer {token}")
            if m in made[other]:
                assert answer.status_code == 404
                continue
            body = answer.json()
            assert (answer.status_code, body["status"]) == (200, m["status"])
            assert [(t["seed"], t["outcome"], t["reason"]) for t in body["trials"]] == m["trials"]
