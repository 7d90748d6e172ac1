"""A submission reads only what it brings: every key that names a file (found in every schema, core and plugin) is
refused at submit when it is absolute, leaves with '..' or names a device, in one line naming the key; a model must
be robokit's or pybullet_data's own; and no reason shown to anyone holds a path of the server."""

from __future__ import annotations

import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

import pytest
from course_helpers import PASSWORD, Course
from course_work import OFFICIAL, make_assignment, submit
from hypothesis import given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
ESCAPES = ["../../../../robokit-server/secret_key", "../secret_key", "models/../../x.urdf", "/etc/passwd",
           "/dev/zero", "/proc/self/environ", "~/secret_key", "C:\\Windows\\win.ini", "\\\\server\\share\\x.urdf"]


@pytest.fixture(autouse=True)
def queued(settings: Any) -> None:
    settings.QUEUE_SYNC = False


def schema_path_keys() -> set[str]:
    """Every key of every schema (core sections and robokit's plugin types) whose description says it names a file,
    a folder or a path: derived from the schemas, so a new such key fails the next test until it is checked."""
    from robokit.checks.config_reference import builtin_types, core_sections, keys_of

    schemas = [cls for _, cls, _ in core_sections()]
    schemas += [t.schema for types in builtin_types().values() for t in types if t.schema is not None]
    words = re.compile(r"\b(file|folder|path|directory)\b", re.I)
    return {k.name for schema in schemas for k in keys_of(schema)
            if "string" in k.type_text and words.search(k.meaning) and not k.name.startswith("save")}


def test_every_key_that_names_a_file_is_checked() -> None:
    from robokit.server.submitted import PATH_KEYS

    found = schema_path_keys()
    assert {"urdf", "sdf", "mjcf", "policy"} <= found  # the generator finds the known ones
    assert found <= set(PATH_KEYS)


def configs_naming(value: str) -> list[tuple[str, str]]:
    """``(config, dotted key)``: the official config with ``value`` at each place a file is named."""
    q = '"' + value.replace("\\", "\\\\") + '"'
    out = [(OFFICIAL + f"\n[{section}.extra]\n{key} = {q}\nposition = [1, 1, 0.5]\n", f"{section}.extra.{key}")
           for section in ("bodies", "robots") for key in ("urdf", "sdf", "mjcf")]
    out.append((OFFICIAL.replace("[behaviour]\n", f"[behaviour]\npolicy = {q}\n", 1), "behaviour.policy"))
    out.append((OFFICIAL + f'\n[monitors.m]\ntype = "policy"\npolicy = {q}\n', "monitors.m.policy"))
    out.append((OFFICIAL + f'\n[report.http]\nurl = "http://x/"\nartifacts_dir = {q}\nverify = {q}\n',
                "report.http.artifacts_dir"))
    out.append((OFFICIAL + f"\n[report.local]\ndir = {q}\n", "report.local.dir"))
    return out


def server_paths() -> list[str]:
    import robokit
    from robokit.server import settings as server_settings

    return [sys.prefix, tempfile.gettempdir(), os.path.expanduser("~"), str(Path(robokit.__file__).parents[1]),
            str(server_settings.DATA_DIR)]


def test_a_path_out_of_the_submission_is_refused_at_submit_naming_the_key(client: Any, course: Course) -> None:
    """Every escape at every place a file is named: 400 naming the key, nothing stored."""
    from robokit.server.models import Submission

    a = make_assignment(course.room, allowed_keys=["*"], max_waiting=100, max_per_day=0)
    for value in ESCAPES:
        for config, key in configs_naming(value):
            resp = submit(client, a.name, config, course.kim_token)
            body = resp.json()
            assert resp.status_code == 400 and body["field"] == key, (value, key, body)
            assert body["error"].startswith(key) and "\n" not in body["error"]
            assert not any(p in body["error"] for p in server_paths()), body["error"]
    assert not Submission.objects.exists()


def test_a_refusal_does_not_tell_which_server_files_exist(client: Any, course: Course) -> None:
    a = make_assignment(course.room, allowed_keys=["*"])
    answers = []
    for value in ("../../../../etc/passwd", "../../../../etc/no-such-file", "/etc/passwd", "/etc/no-such-file",
                  "passwd.urdf", "no-such-file.urdf"):
        config, _ = configs_naming(value)[0]
        answers.append(submit(client, a.name, config, course.kim_token).json()["error"].replace("passwd",
                                                                                                 "no-such-file"))
    assert answers[0] == answers[1] and answers[2] == answers[3] and answers[4] == answers[5]


def test_packaged_models_are_accepted(client: Any, course: Course) -> None:
    a = make_assignment(course.room, allowed_keys=["*"], max_waiting=100, max_per_day=0)
    for name in ("r2d2.urdf", "franka_panda/panda.urdf", "robots/diffbot.urdf"):
        config = OFFICIAL + f'\n[robots.extra]\nurdf = "{name}"\nposition = [2, 2, 0.5]\n'
        resp = submit(client, a.name, config, course.kim_token)
        assert resp.status_code == 201, (name, resp.content)
    missing = submit(client, a.name, OFFICIAL + '\n[robots.extra]\nurdf = "robots/nothere.urdf"\n'
                     'position = [2, 2, 0.5]\n', course.kim_token)
    body = missing.json()
    assert missing.status_code == 400 and body["field"] == "robots.extra.urdf" and "bundled" in body["error"]
    assert not any(p in body["error"] for p in server_paths())


def test_no_reason_shown_to_anyone_holds_a_server_path(client: Any, course: Course) -> None:
    """An official trial whose reason (and a submission whose error) names the server's venv, scratch folder,
    home and data folder: the student's page and API, the teacher's submission and run pages and the reasons
    chart show none of those paths, and a packaged model by its packaged name."""
    import pybullet_data

    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0,))
    paths = server_paths()
    model = str(Path(pybullet_data.getDataPath()) / "r2d2.urdf")
    reason = "aborted: cannot read " + " and ".join(f"{p}/secret_key" for p in paths) + f"; loaded {model}"
    sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done",
                                    trials=1, succeeded=0, success_rate=0.0, error=f"see {paths[1]}/robokit-eval-1")
    Result.objects.create(run_id="r-1", classroom=course.room, project=a.project, student=course.kim,
                          student_name=course.kim.name, verified=True, official=True, outcome="aborted",
                          reason=reason, seed=0, submission=sub,
                          payload={"reason": reason, "config": f"file://{paths[1]}/robokit-eval-1/a.toml"})
    client.post("/me/", {"token": course.kim_token})
    shown = [client.get("/me/").content.decode(),
             client.get(f"/api/robotics/submissions/{sub.pk}/", HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
             .content.decode()]
    client.login(username="teacher", password=PASSWORD)
    shown += [client.get(url).content.decode() for url in (
        f"/submissions/{sub.pk}/", "/runs/r-1/", f"/classes/{course.room.pk}/assignments/{a.pk}/reasons.svg")]
    for page in shown:
        assert "secret_key" in page or "<svg" in page
        for p in paths:
            assert p not in page, (p, page[:300])
    assert "pybullet_data/r2d2.urdf" in shown[0]


def test_an_official_trial_is_stored_without_server_paths(client: Any, course: Course) -> None:
    """What the evaluation stores (the reason, and the reason and error in the kept payload) holds no server path,
    so the admin's read-only pages show none either."""
    from robokit.server.evaluation import store_trial
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, seeds=(0,))
    sub = Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL)
    paths = server_paths()
    reason = "failed: " + ", ".join(f"{p}/x.urdf" for p in paths)
    store_trial(sub, {"run_id": "r-2", "key": "seed=0", "seed": 0, "outcome": "failed", "reason": reason,
                      "error": f"in {paths[1]}/robokit-eval-9", "figures": {}, "result": {}})
    stored = Result.objects.get(run_id="r-2")
    course.teacher.is_superuser = True
    course.teacher.save()
    client.login(username="teacher", password=PASSWORD)
    admin = client.get(f"/admin/course/result/{stored.pk}/change/").content.decode()
    for text in (stored.reason, str(stored.payload), admin):
        assert "x.urdf" in text and not any(p in text for p in paths), text[:500]


_SEGMENT = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789_-.", min_size=1, max_size=12).filter(
    lambda s: s not in (".", ".."))
_WORD = st.text(alphabet="abcdefghijklmnopqrstuvwxyz가나다 ", min_size=1, max_size=10)


@settings(max_examples=100, deadline=None)
@given(parts=st.lists(st.tuples(_WORD, st.integers(0, 4), st.lists(_SEGMENT, min_size=1, max_size=4)),
                      min_size=1, max_size=4),
       wrap=st.sampled_from(["{}", "'{}'", '"{}"', "({})", "{}:", "file://{}", "{},"]))
def test_scrub_takes_out_every_server_folder(parts: list[tuple[str, int, list[str]]], wrap: str) -> None:
    """Generated reasons: words, and paths under the server's folders (venv, scratch, home, checkout, data) in
    quotes, brackets or a file URL. No folder survives; each path's last part and every word do; scrubbing twice
    changes nothing more."""
    from robokit.server.submitted import scrub

    roots = server_paths()
    text, words, names = "", [], []
    for word, root, segments in parts:
        path = "/".join([roots[root], *segments])
        text += f"{word} {wrap.format(path)} "
        words.append(word.strip())
        names.append(segments[-1])
    out = scrub(text)
    assert not any(root in out for root in roots), out
    assert all(w in out for w in words) and all(n in out for n in names), out
    assert scrub(out) == out
