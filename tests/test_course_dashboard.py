"""The learning dashboard: training logs posted with a token, a student's weeks and failure reasons, the class's
assignment page (who has submitted), and the charts (SVG from matplotlib, every Korean glyph found in a font)."""

from __future__ import annotations

import datetime as dt
import json
import warnings
from typing import Any
from xml.etree import ElementTree as ET

import pytest
from course_helpers import PASSWORD, Course, post, robokit_payload
from course_work import OFFICIAL, make_assignment

pytest_plugins = ["course_fixtures"]
pytestmark = pytest.mark.django_db
LOG = "\n".join(json.dumps({"steps": 1000 * i, "episodes": 10 * i, "return": -5.0 + i, "success_rate": i / 10})
                for i in range(1, 11))


def post_training(client: Any, token: str, body: dict[str, Any]) -> Any:
    return client.post("/api/robotics/training/", data=json.dumps(body), content_type="application/json",
                       HTTP_AUTHORIZATION=f"Bearer {token}")


def test_a_training_log_is_stored_once_for_the_token_owner(client: Any, course: Course) -> None:
    from robokit.server.models import TrainingRun

    first = post_training(client, course.kim_token, {"run_id": "ars-1", "name": "ARS reach", "log": LOG})
    assert first.status_code == 201 and first.json() == {"run_id": "ars-1", "name": "ARS reach", "points": 10,
                                                         "student": "김민준"}
    assert post_training(client, course.kim_token, {"run_id": "ars-1", "log": LOG}).status_code == 200
    assert post_training(client, course.lee_token, {"run_id": "ars-1", "log": LOG}).status_code == 409
    run = TrainingRun.objects.get()
    assert run.student == course.kim and run.points[2] == {"steps": 3000, "episodes": 30, "return": -2.0,
                                                           "success_rate": 0.3}


@pytest.mark.parametrize(("log", "field"), [
    ('{"steps": 1}\n{"steps": "2"}', "log[2].steps"),
    ('{"steps": 1}\nnot json', "log[2]"),
    ('{"steps": 1, "success_rate": 1.5}', "log[1].success_rate"),
    ("", "log"),
])
def test_a_bad_training_log_is_a_400_naming_the_line(client: Any, course: Course, log: str, field: str) -> None:
    resp = post_training(client, course.kim_token, {"log": log})
    assert resp.status_code == 400 and resp.json()["field"] == field


def _store_runs(client: Any, course: Course) -> None:
    """Three runs of 김민준 over two weeks: two failures with alike reasons (they group), one success."""
    from robokit.server.models import Result

    for i, (outcome, reason, day) in enumerate([("failed", "dropped cube 1 at 3.5 s", 2),
                                                ("failed", "dropped cube 2 at 7.0 s", 3),
                                                ("succeeded", "sorted", 10)]):
        payload = {**robokit_payload(i), "outcome": outcome, "reason": reason}
        assert post(client, payload, course.kim_token).status_code == 201
        Result.objects.filter(run_id=payload["run_id"]).update(
            received_at=dt.datetime(2026, 11, day, 12, tzinfo=dt.timezone.utc))


def test_the_student_dashboard_shows_weeks_reasons_and_training(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    _store_runs(client, course)
    post_training(client, course.kim_token, {"name": "ARS reach", "log": LOG})
    a = make_assignment(course.room)
    for rate, day in ((0.25, 4), (0.5, 5)):  # both evaluated in week 45: the best is 0.50
        Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done",
                                  trials=4, succeeded=int(4 * rate), success_rate=rate,
                                  finished_at=dt.datetime(2026, 11, day, tzinfo=dt.timezone.utc))
    client.login(username="teacher", password=PASSWORD)
    page = client.get(f"/classes/{course.room.pk}/students/{course.kim.pk}/dashboard/").content.decode()
    # 2026-11-02 and 11-03 are in ISO week 45, 11-10 in week 46: 0 of 2, then 1 of 1.
    cells = '<td class="num">{}</td>' * 4
    assert "2026-W45</td>" + cells.format(2, 0, "0.00", "0.50") in page
    assert "2026-W46</td>" + cells.format(1, 1, "1.00", "—") in page
    assert "dropped cube N at N s</td><td class=\"num\">2</td>" in page
    assert "ARS reach: 10 points" in page and 'id="chart-training"' in page


def _svg_of(client: Any, url: str) -> ET.Element:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # matplotlib warns "Glyph ... missing from font(s)" for tofu
        resp = client.get(url)
    assert resp.status_code == 200 and resp["Content-Type"] == "image/svg+xml"
    assert "sandbox" in resp["Content-Security-Policy"]
    root = ET.fromstring(resp.content)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    return root


def test_charts_are_svg_with_korean_text_drawn_from_a_font(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    _store_runs(client, course)
    post_training(client, course.kim_token, {"name": "학습 1", "log": LOG})
    a = make_assignment(course.room, "낙하 실험")
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done", trials=2,
                              succeeded=1, success_rate=0.5, wilson_low=0.1, wilson_high=0.9,
                              finished_at=dt.datetime(2026, 11, 5, tzinfo=dt.timezone.utc))
    client.login(username="teacher", password=PASSWORD)
    base = f"/classes/{course.room.pk}/students/{course.kim.pk}"
    for kind in ("timeline", "weekly", "training"):
        root = _svg_of(client, f"{base}/{kind}.svg")
        assert len(root.findall(".//{http://www.w3.org/2000/svg}path")) > 20  # text is drawn as outlines
    for kind in ("distribution", "reasons"):
        _svg_of(client, f"/classes/{course.room.pk}/assignments/{a.pk}/{kind}.svg")
    assert client.get(f"{base}/nope.svg").status_code == 404


def test_the_assignment_page_says_who_has_not_submitted(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, "낙하 실험")
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="queued")
    client.login(username="teacher", password=PASSWORD)
    page = client.get(f"/classes/{course.room.pk}/assignments/{a.pk}/").content.decode()
    assert "(1 not yet)" in page and "not submitted" in page and "queued 1" in page
    assert "&lt;script&gt;alert(&#x27;x&#x27;)&lt;/script&gt;" in page  # the other student's name, as text
    assert '<dd id="limits">1 waiting at a time, 10 in any 24 hours</dd>' in page
    room_page = client.get(f"/classes/{course.room.pk}/").content.decode()
    assert f"/classes/{course.room.pk}/assignments/{a.pk}/" in room_page and "grades.csv" in room_page


def test_a_student_sees_their_own_submissions_and_official_results(client: Any, course: Course) -> None:
    from robokit.server.models import Submission

    a = make_assignment(course.room, "낙하 실험")
    Submission.objects.create(assignment=a, student=course.kim, config_text=OFFICIAL, status="done", trials=20,
                              succeeded=15, success_rate=0.75, wilson_low=0.53, wilson_high=0.89, late=True)
    Submission.objects.create(assignment=a, student=course.lee, config_text=OFFICIAL, status="done", trials=20,
                              succeeded=3, success_rate=0.15, wilson_low=0.05, wilson_high=0.36)
    assert client.post("/me/", {"token": course.kim_token}).status_code == 302
    page = client.get("/me/").content.decode()
    assert "15/20 (0.75, 95 % 0.53–0.89)" in page and "late" in page
    assert "3/20" not in page  # another student's submission


def test_a_training_log_over_the_limit_is_413_not_an_error(client: Any, course: Course, settings: Any) -> None:
    line = json.dumps({"steps": 1, "return": 0.5}) + "\n"
    body = {"log": line * (settings.MAX_RESULT_BYTES // len(line) + 10)}
    resp = post_training(client, course.kim_token, body)
    assert resp.status_code == 413 and "limit" in resp.json()["error"]


HIDE_SYSTEM_KOREAN = """
import json, sys, warnings
from matplotlib import font_manager

def korean(entry):
    try:
        return font_manager.get_font(entry.fname).get_char_index(ord("한")) != 0
    except Exception:
        return False

# a machine without a system Korean font: none in matplotlib's (fresh) font list, none at the usual files
font_manager.fontManager.ttflist = [f for f in font_manager.fontManager.ttflist if not korean(f)]
import robokit.record.fonts as fonts
fonts.SYSTEM_FILES = ()
if sys.argv[1] == "no-package":
    sys.modules["pylopdf_fonts_ko"] = None  # nor the packaged font: import fails
fonts.warn_if_no_korean_font()  # as the server's start does
from robokit.server import charts
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    svgs = [charts.reasons("실패 이유", [("물체를 놓침", 3)]).decode(),
            charts.distribution("학생별 성공률", [0.5, 1.0], "공식 성공률").decode()]
path = fonts.korean_font_file()
print(json.dumps({"svgs": svgs, "warnings": [str(w.message) for w in caught],
                  "font": str(path) if path else None}))
"""


def _charts_without_system_korean(tmp_path: Any, mode: str) -> tuple[dict[str, Any], str]:
    import os
    import subprocess
    import sys

    env = {**os.environ, "MPLCONFIGDIR": str(tmp_path / mode)}  # a fresh matplotlib font cache
    out = subprocess.run([sys.executable, "-c", HIDE_SYSTEM_KOREAN, mode], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout), out.stderr


@pytest.mark.slow
def test_korean_charts_need_no_system_font_and_no_font_cache(tmp_path: Any) -> None:
    """With no Korean font on the system and a fresh font cache, charts still draw every Hangul glyph from the
    packaged Noto Sans KR: each character's glyph (its index looked up in the font file) is in the SVG."""
    from matplotlib.ft2font import FT2Font

    found, stderr = _charts_without_system_korean(tmp_path, "packaged")
    assert found["font"] is not None and found["font"].endswith("NotoSansKR-Regular.otf")
    assert not found["warnings"] and "Korean" not in stderr
    font = FT2Font(found["font"])
    for svg, text in zip(found["svgs"], ("실패 이유 물체를 놓침", "학생별 성공률 공식"), strict=True):
        for char in set(text) - {" "}:
            index = font.get_char_index(ord(char))
            assert index != 0 and f'id="NotoSansKR-Regular-{index:x}"' in svg, char


@pytest.mark.slow
def test_without_any_korean_font_one_warning_not_one_per_glyph(tmp_path: Any) -> None:
    found, stderr = _charts_without_system_korean(tmp_path, "no-package")
    assert found["font"] is None and all("<svg" in s for s in found["svgs"])
    assert not [w for w in found["warnings"] if "Glyph" in w]
    assert stderr.count("no Korean font found") == 1 and "fonts-nanum" in stderr


@pytest.mark.slow
def test_charts_drawn_on_many_threads_at_once_equal_the_same_charts_drawn_one_by_one() -> None:
    """The server draws charts on its request threads: a chart must not depend on what another thread draws."""
    from concurrent.futures import ThreadPoolExecutor

    from robokit.server import charts

    jobs = [lambda i=i: charts.reasons(f"실패 이유 {i}", [("물체를 놓침", i + 1), ("timeout", 2 * i + 1)])
            for i in range(3)]
    jobs += [lambda i=i: charts.distribution(f"학생별 성공률 {i}", [0.1 * i, 0.5, 1.0], "공식 성공률")
             for i in range(3)]
    alone = [job() for job in jobs]
    with ThreadPoolExecutor(max_workers=6) as pool:
        together = list(pool.map(lambda job: job(), jobs * 2))
    assert together == alone * 2
    assert len(set(alone)) == len(alone)  # every chart differs from the others: a mix-up would show
