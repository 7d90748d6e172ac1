"""A student's own plugin package with a submission, only where the assignment allows it: refused (403) elsewhere,
checked without being imported here (names, size, syntax, no shadowing of installed modules), its config loaded
with it in a sandbox process at submit time (a bad option of the plugin's own type is a 400 naming it), and
imported only in the evaluation's sandbox process, where the official trials run with it (the queue in django-q2's
synchronous mode)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from course_helpers import PASSWORD, Course
from course_work import OFFICIAL, make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
MINE = OFFICIAL.replace('type = "drop_test"', 'type = "careful_drop"')
PLUGIN = {
    "careful_drop/__init__.py": (
        "from robokit import hookimpl\n"
        "from careful_drop.behaviour import CarefulDrop\n\n"
        "@hookimpl\n"
        "def robokit_register_behaviours(register):\n"
        "    register('careful_drop', CarefulDrop, CarefulDrop.Config)\n"),
    "careful_drop/behaviour.py": (
        "from pydantic import Field\n"
        "from robokit_behaviours.drop_test import DropTest, DropTestConfig\n\n"
        "class CarefulConfig(DropTestConfig):\n"
        "    care: int = Field(7, ge=1)\n\n"
        "class CarefulDrop(DropTest):\n"
        "    Config = CarefulConfig\n\n"
        "    def result(self):\n"
        "        out = super().result()\n"
        "        out['careful'] = self.config.care\n"
        "        return out\n"),
}
"""A behaviour type of the student's own, with an option of its own (``care``, a whole number >= 1)."""


@pytest.fixture(autouse=True)
def sync_queue(settings: Any) -> None:
    settings.QUEUE_SYNC = True


def send(client: Any, name: str, token: str, config: str, files: Any) -> Any:
    return client.post(f"/api/robotics/assignments/{name}/submissions/", content_type="application/json",
                       data=json.dumps({"config": config, "plugin_files": files}), HTTP_AUTHORIZATION=f"Bearer {token}")


def test_a_plugin_is_refused_where_the_assignment_does_not_allow_it(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"])
    resp = send(client, a.name, course.kim_token, MINE, PLUGIN)
    assert resp.status_code == 403 and resp.json()["field"] == "plugin"
    assert "does not accept plugin packages" in resp.json()["error"]
    assert not Submission.objects.exists()


@pytest.mark.parametrize(("files", "words"), [
    ({"careful_drop/__init__.py": "def broken(:\n"}, "careful_drop/__init__.py line 1: invalid syntax"),
    ({"../evil.py": "x = 1\n"}, "expected a Python module path"),
    ({"careful_drop/behaviour.py": "x = 1\n"}, "a package needs careful_drop/__init__.py"),
    ({"json.py": "x = 1\n"}, "'json' is the name of a module installed on the server"),
    ({"robokit_extra.py": "x = 1\n"}, "'robokit_extra' is the name of a module installed"),
    ({"big.py": "x = 1\n" * 50_000}, "bytes of source; the limit is"),
    (["careful_drop.py"], "expected {"),
])
def test_a_bad_plugin_is_refused_in_one_line_without_being_imported(client: Any, course: Course, files: Any,
                                                                     words: str) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True)
    resp = send(client, a.name, course.kim_token, MINE, files)
    assert resp.status_code in (400, 413) and resp.json()["field"] == "plugin", resp.content
    assert words in resp.json()["error"] and "\n" not in resp.json()["error"]
    assert not Submission.objects.exists()


def test_the_official_trials_run_with_the_students_plugin_in_the_sandbox(client: Any, course: Course) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True, seeds=(0, 1))
    resp = send(client, a.name, course.kim_token, MINE, PLUGIN)
    assert resp.status_code == 201, resp.content
    assert resp.json()["plugins"] == ["careful_drop"]
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded, sub.error) == ("done", 2, 2, ""), sub.summary
    rows = list(Result.objects.filter(submission=sub).order_by("seed"))
    assert [r.behaviour for r in rows] == ["careful_drop", "careful_drop"]
    assert [r.figures.get("careful") for r in rows] == [7, 7]  # computed by the student's code, in the sandbox
    client.login(username="teacher", password=PASSWORD)
    page = client.get(f"/submissions/{sub.pk}/").content.decode()
    assert "careful_drop/behaviour.py" in page and "out[&#x27;careful&#x27;] = self.config.care" in page  # read it
    assert "allowed (run only in the evaluation sandbox)" in client.get(
        f"/classes/{course.room.pk}/assignments/{a.pk}/").content.decode()


@pytest.mark.parametrize(("line", "field", "words"), [
    ("care = 0", "behaviour.care", "greater than or equal to 1"),       # the plugin's own option, out of range
    ("cair = 3", "behaviour.cair", "'care'"),                            # unknown: did you mean the plugin's own
    ('care = "much"', "behaviour.care", "integer"),
])
@pytest.mark.slow
def test_a_bad_option_of_the_plugins_own_type_is_refused_at_submit(client: Any, course: Course, line: str,
                                                                   field: str, words: str) -> None:
    import sys

    from robokit.server.models import Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True)
    resp = send(client, a.name, course.kim_token, MINE.replace("[behaviour]\n", f"[behaviour]\n{line}\n"), PLUGIN)
    assert resp.status_code == 400, resp.content
    body = resp.json()
    assert body["field"] == field and body["error"].startswith(f"{field}: "), body
    assert words in body["error"] and "\n" not in body["error"], body
    assert not Submission.objects.exists()  # refused before anything was stored or queued
    assert "careful_drop" not in sys.modules  # loaded in the sandbox's process, never in the server's


@pytest.mark.slow
def test_a_good_option_of_the_plugins_own_type_is_accepted_and_used(client: Any, course: Course) -> None:
    from robokit.server.models import Result, Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True, seeds=(3,))
    resp = send(client, a.name, course.kim_token, MINE.replace("[behaviour]\n", "[behaviour]\ncare = 3\n"), PLUGIN)
    assert resp.status_code == 201, resp.content
    sub = Submission.objects.get()
    assert (sub.status, sub.trials, sub.succeeded) == ("done", 1, 1), sub.error
    assert Result.objects.get(submission=sub).figures["careful"] == 3  # the option reached the student's code


@pytest.mark.parametrize(("source", "words"), [
    ("raise RuntimeError('not ready')\n", "RuntimeError: not ready"),
    ("import numpy_not_here\n", "No module named 'numpy_not_here'"),
])
def test_a_plugin_that_fails_to_import_is_refused_at_submit(client: Any, course: Course, source: str,
                                                            words: str) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True)
    files = {**PLUGIN, "careful_drop/__init__.py": source + PLUGIN["careful_drop/__init__.py"]}
    resp = send(client, a.name, course.kim_token, MINE, files)
    assert resp.status_code == 400 and resp.json()["field"] == "plugin", resp.content
    assert words in resp.json()["error"] and "\n" not in resp.json()["error"]
    assert not Submission.objects.exists()


@pytest.mark.slow
def test_a_plugin_that_never_finishes_loading_is_refused_after_the_check_time_limit(
        client: Any, course: Course, monkeypatch: pytest.MonkeyPatch) -> None:
    from robokit.server import sandbox
    from robokit.server.models import Submission

    monkeypatch.setattr(sandbox, "CHECK_SECONDS", 1.0)
    a = make_assignment(course.room, allowed_keys=["behaviour.*"], allow_plugins=True)
    files = {**PLUGIN, "careful_drop/__init__.py": "while True:\n    pass\n"}
    resp = send(client, a.name, course.kim_token, MINE, files)
    assert resp.status_code == 400 and resp.json()["field"] == "plugin", resp.content
    assert "did not finish in 1 s" in resp.json()["error"]
    assert not Submission.objects.exists()


def write_package(folder: Path) -> None:
    """The student's plugin package as files in ``folder`` (what ``robokit submit --plugin`` reads)."""
    for rel, source in PLUGIN.items():
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_text(source, encoding="utf-8")


@pytest.mark.slow
def test_robokit_submit_sends_a_package_folder(live_server: Any, course: Course, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    from robokit.cli import main
    from robokit.server.models import Submission

    a = make_assignment(course.room, "plugins", allowed_keys=["behaviour.*"], allow_plugins=True, seeds=(0,))
    write_package(tmp_path)
    (tmp_path / "careful_drop" / "__pycache__").mkdir()
    (tmp_path / "careful_drop" / "__pycache__" / "x.py").write_text("not sent", encoding="utf-8")
    (tmp_path / "mine.toml").write_text(MINE, encoding="utf-8")
    monkeypatch.setenv("ROBOKIT_TOKEN", course.kim_token)
    args = ["submit", a.name, str(tmp_path / "mine.toml"), "--url", live_server.url + "/", "--plugin",
            str(tmp_path / "careful_drop")]
    assert main(args) == 0
    assert "with your plugin careful_drop, queued for official evaluation on 1 seeds" in capsys.readouterr().out
    assert Submission.objects.get().plugin_files == PLUGIN


def test_robokit_submit_shows_a_refused_plugin_config_and_fails(live_server: Any, course: Course, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from robokit.cli import main
    from robokit.server.models import Submission

    a = make_assignment(course.room, "plugins", allowed_keys=["behaviour.*"], allow_plugins=True, seeds=(0,))
    write_package(tmp_path)
    (tmp_path / "mine.toml").write_text(MINE.replace("[behaviour]\n", "[behaviour]\ncare = 0\n"), encoding="utf-8")
    monkeypatch.setenv("ROBOKIT_TOKEN", course.kim_token)
    code = main(["submit", a.name, str(tmp_path / "mine.toml"), "--url", live_server.url + "/", "--plugin",
                 str(tmp_path / "careful_drop")])
    err = capsys.readouterr().err
    assert code != 0
    assert "behaviour.care: " in err and "greater than or equal to 1" in err and len(err.strip().splitlines()) == 1
    assert not Submission.objects.exists()
