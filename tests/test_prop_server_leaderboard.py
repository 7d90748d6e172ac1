"""A project's leaderboard against the runs posted, over generated posts in all three tables (docs/server.md, "What
the teacher sees").

Each student's best run, best first, in three tables: students' runs (posted with a student's token, counted for the
token's owner -- also after the teacher renames the student), official runs (a teacher's token) and runs posted
without a token (under the name posted, or the student of that name); an excluded run is on no table. "Best"
follows the project's ranking: successful runs (and outcome-less posts) first, then the ranking's figures in order (a
missing one last), then the earlier run. The columns are the ranking's figures first, then every other figure the
runs reported.

Expected here: each run's owner as the post made it, the best by a chain of stable sorts (the ranking's last key
first), every cell the figure as posted.
"""

from __future__ import annotations

import re
from typing import Any

from course_helpers import PASSWORD, post
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=10, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
RANKINGS = ("-collected,failures", "total_time", "speed,-collected", "-speed", "failures,total_time,-collected")
FIGURES = {"collected": st.integers(0, 3), "failures": st.integers(0, 2),
           "total_time": st.sampled_from([7.5, 12.25, 9.125]), "speed": st.sampled_from([0.5, 0.75, 1.25])}
run = st.fixed_dictionaries({
    "who": st.sampled_from(["kim", "lee", "teacher", None]), "name": st.sampled_from(["김민준", "민서", "Kim"]),
    "outcome": st.sampled_from([None, "succeeded", "failed", "aborted"]),
    "figures": st.fixed_dictionaries({}, optional=FIGURES), "rename_before": st.booleans(),
    "excluded": st.sampled_from([False, False, False, True])})


def ranked(runs: list[dict[str, Any]], ranking: str) -> list[dict[str, Any]]:
    out = sorted(runs, key=lambda r: r["i"])
    for part in reversed(ranking.split(",")):
        name, higher = part.lstrip("-"), part.startswith("-")
        present = sorted((r for r in out if name in r["figures"]), key=lambda r: r["figures"][name], reverse=higher)
        out = present + [r for r in out if name not in r["figures"]]
    return [r for r in out if r["outcome"] in (None, "succeeded")] + [
        r for r in out if r["outcome"] not in (None, "succeeded")]


@PROPS
@given(runs=st.lists(run, min_size=1, max_size=8), ranking=st.sampled_from(RANKINGS))
def test_every_table_of_the_leaderboard_is_each_owners_best_run(client: Any, course: Any,
                                                                 runs: list[dict[str, Any]], ranking: str) -> None:
    from robokit.server.models import Project, Result, Student

    Result.objects.all().delete()
    Project.objects.filter(name="P").delete()
    Student.objects.filter(pk=course.kim.pk).update(name="김민준")
    project = Project.objects.create(classroom=course.room, name="P", ranking=ranking)
    tokens = {"kim": course.kim_token, "lee": course.lee_token, "teacher": course.teacher_token, None: None}
    renamed = False
    for i, r in enumerate(runs):
        if r["rename_before"] and not renamed:  # the teacher renames 김민준 in the admin, between two posts
            Student.objects.filter(pk=course.kim.pk).update(name="김민준 (2)")
            renamed = True
        body = {"project": "P", "student": r["name"], "run_id": f"lb-{i}", **r["figures"]}
        if r["outcome"]:
            body["outcome"] = r["outcome"]
        assert post(client, body, tokens[r["who"]]).status_code == 201
        if r["excluded"]:  # the teacher excluded it (moderation): off the board
            Result.objects.filter(run_id=f"lb-{i}").update(excluded=True)
        names = dict(Student.objects.filter(classroom=course.room).values_list("name", "pk"))
        r["i"], r["run_id"] = i, f"lb-{i}"
        r["owner"] = ({"kim": course.kim.pk, "lee": course.lee.pk}[r["who"]] if r["who"] in ("kim", "lee")
                      else names.get(r["name"], r["name"]))
        r["table"] = {"kim": "students", "lee": "students", "teacher": "official", None: "unverified"}[r["who"]]
    assert client.login(username="teacher", password=PASSWORD)
    page = client.get(f"/classes/{course.room.pk}/projects/{project.pk}/").content.decode()

    keys = ranking.split(",")
    students = page[page.index('id="students"'):]
    head = re.findall(r'<th class="num"><a href="\?sort=[^"]*">([^<]+)</a>', students[:students.index("</thead>")])
    seen = {k for r in runs if not r["excluded"] for k in r["figures"]}
    wanted = [k.lstrip("-") for k in keys]
    assert head[:len(wanted)] == wanted and set(head) == set(wanted) | seen  # at most 4 figures: all shown
    assert len(head) == len(set(head))  # each once
    for table in ("students", "official", "unverified"):
        mine = [r for r in runs if r["table"] == table and not r["excluded"]]
        if not mine and table != "students":
            assert f'id="{table}"' not in page
            continue
        best: dict[Any, dict[str, Any]] = {}
        for r in ranked(mine, ranking):
            best.setdefault(r["owner"], r)
        expected = ranked(list(best.values()), ranking)
        section = page[page.index(f'id="{table}"'):]
        section = section[:section.index("</section>")]
        rows = re.findall(r'<td><a href="/runs/([^/]+)/".*?</tr>', section, re.S)
        assert rows == [r["run_id"] for r in expected], table
        for r, row in zip(expected, re.findall(r'<td><a href="/runs/[^/]+/".*?</tr>', section, re.S),
                          strict=True):
            cells = re.findall(r'<td class="num">([^<]*)</td>', row)
            assert cells == [str(r["figures"][h]) if h in r["figures"] else "—" for h in head], (table, row)
