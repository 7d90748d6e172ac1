"""A training run posted to the course server as a student does it: ``python -m robokit.gym.post LOG
--report-url URL`` (and ``python -m robokit.gym.train ... --report-url URL``, which posts the same file when it ends)
sends ``progress.jsonl`` with the token to a live server; the student's dashboard lists it and draws its curves.

The log is made here by a short run of random actions (torch is only in the slow tier), written line by line with
the train module's own line format."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from course_helpers import Course

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
ROOT = Path(__file__).resolve().parents[1]
SVG = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def progress(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``reach-random-s0/progress.jsonl``: 4 episodes of random actions on the reach env, a line after each, and
    the summary line train ends with."""
    from robokit.gym import make
    from robokit.gym.train import progress_line

    env = make(str(ROOT / "configs" / "gym" / "reach.toml"))
    env.action_space.seed(0)
    steps, returns, successes, lines = 0, [], [], []
    for episode in range(4):
        env.reset(seed=episode)
        done, total = False, 0.0
        while not done:
            _, reward, terminated, truncated, info = env.step(env.action_space.sample())
            steps, total, done = steps + 1, total + float(reward), terminated or truncated
        returns.append(total)
        successes.append(bool(info["is_success"]))
        lines.append(progress_line(steps, episode + 1, returns, successes, 0.1 * steps))
    env.close()
    lines.append({"summary": {"method": "random", "env_steps": steps, "eval_success_rate": 0.0}})
    folder = tmp_path_factory.mktemp("train") / "reach-random-s0"
    folder.mkdir()
    path = folder / "progress.jsonl"
    path.write_text("".join(json.dumps(line) + "\n" for line in lines), encoding="utf-8")
    return path


def _vertices(svg: bytes, gid: str) -> list[tuple[float, float]]:
    """The points of the line drawn in the SVG group ``gid`` (matplotlib's ``M x y L x y ...``)."""
    group = next(g for g in ET.fromstring(svg).iter(f"{SVG}g") if g.get("id") == gid)
    d = next(group.iter(f"{SVG}path")).get("d", "")
    numbers = [float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", d)]
    return list(zip(numbers[::2], numbers[1::2], strict=True))


@pytest.mark.slow
def test_a_training_log_posted_by_the_student_is_plotted_on_their_dashboard(
        live_server: Any, course: Course, client: Any, progress: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from robokit.gym.post import main
    from robokit.server.models import TrainingRun

    url = live_server.url + "/api/robotics/result/"  # the URL robokit run --report-url takes
    monkeypatch.setenv("ROBOKIT_TOKEN", course.kim_token)
    assert main([str(progress), "--report-url", url]) == 0
    out = capsys.readouterr().out
    assert out.startswith("training log posted: 4 points as 'reach-random-s0' for 김민준")
    assert course.kim_token not in out
    assert main([str(progress), "--report-url", url]) == 0  # the same log again: stored once
    assert "(already there)" in capsys.readouterr().out

    lines = [json.loads(line) for line in progress.read_text(encoding="utf-8").splitlines()][:-1]
    run = TrainingRun.objects.get()
    assert run.student == course.kim and run.name == "reach-random-s0"
    assert run.points == [{"steps": line["env_steps"], "episodes": line["episodes"], "return": line["return_mean"],
                           "success_rate": line["success_rate"]} for line in lines]

    client.force_login(course.teacher)
    base = f"/classes/{course.room.pk}/students/{course.kim.pk}"
    page = client.get(f"{base}/dashboard/").content.decode()
    assert "reach-random-s0: 4 points" in page and 'id="chart-training"' in page
    svg = client.get(f"{base}/training.svg").content
    curve = _vertices(svg, "return-0")
    assert len(curve) == 4 and [x for x, _ in curve] == sorted(x for x, _ in curve)  # one vertex per line, in order
    ys = [y for _, y in curve]  # SVG y grows downwards: the higher mean return, the smaller y
    means = [line["return_mean"] for line in lines]
    assert np.argsort(ys).tolist() == np.argsort(means)[::-1].tolist() or len(set(means)) < 4
    assert len(_vertices(svg, "success-0")) == 4

    client.logout()  # the student, on their own page
    assert client.get("/me/training.svg").status_code == 404  # not before the token opened the session
    assert client.post("/me/", {"token": course.kim_token}).status_code == 302
    mine = client.get("/me/").content.decode()
    assert "My training runs" in mine and "reach-random-s0: 4 points" in mine and 'id="my-training"' in mine
    assert len(_vertices(client.get("/me/training.svg").content, "return-0")) == 4


def test_a_bad_url_or_a_missing_token_stops_train_before_it_trains(monkeypatch: pytest.MonkeyPatch,
                                                                    capsys: pytest.CaptureFixture[str],
                                                                    tmp_path: Path) -> None:
    from robokit.gym.train import main

    config = str(ROOT / "configs" / "gym" / "reach.toml")
    monkeypatch.delenv("ROBOKIT_TOKEN", raising=False)
    out = ["--out", str(tmp_path / "run")]
    assert main([config, *out, "--report-url", "ftp://host/x"]) == 2
    assert capsys.readouterr().err == "train: error: --report-url 'ftp://host/x': expected " \
                                      "http(s)://HOST[:PORT]/api/robotics/result/\n"
    assert main([config, *out, "--report-url", "http://host/api/robotics/result/"]) == 2
    assert capsys.readouterr().err.startswith("train: error: environment variable ROBOKIT_TOKEN is not set")
    assert not (tmp_path / "run").exists()  # nothing was trained


@pytest.mark.parametrize(("url", "expected"), [
    ("http://h:8000/api/robotics/result/", "http://h:8000/api/robotics/training/"),
    ("http://h:8000/api/robotics/result", "http://h:8000/api/robotics/training/"),
    ("https://h/course/api/robotics/result/", "https://h/course/api/robotics/training/"),
    ("http://h:8000/", "http://h:8000/api/robotics/training/"),
    ("http://h:8000/api/robotics/training/", "http://h:8000/api/robotics/training/"),
])
def test_the_training_endpoint_is_found_from_the_results_url(url: str, expected: str) -> None:
    from robokit.gym.post import training_url

    assert training_url(url) == expected


def test_train_posts_its_progress_log_when_it_ends(live_server: Any, course: Course, progress: Path, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """The training itself (stable-baselines3, torch: slow tier) stands aside here: ``train`` writes the random
    run's log into the run folder, as the real one does; what is tested is what ``main`` does after it."""
    import robokit.gym.train as train_module
    from robokit.server.models import TrainingRun

    def fake_train(args: Any, log: Any = print) -> dict[str, Any]:
        folder = train_module.run_folder(args)
        folder.mkdir(parents=True)
        (folder / "progress.jsonl").write_text(progress.read_text(encoding="utf-8"), encoding="utf-8")
        return {}

    monkeypatch.setattr(train_module, "train", fake_train)
    monkeypatch.setenv("LEE_TOKEN", course.lee_token)
    config = str(ROOT / "configs" / "gym" / "reach.toml")
    args = [config, "--out", str(tmp_path / "reach-ppo-s0"), "--report-url", live_server.url + "/api/robotics/result/",
            "--token-env", "LEE_TOKEN"]
    assert train_module.main(args) == 0
    assert f"training log posted: 4 points as 'reach-ppo-s0' for {course.lee.name} at" in capsys.readouterr().out
    assert TrainingRun.objects.get().student == course.lee
