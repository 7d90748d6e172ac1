"""The course server's rules, each from docs/server.md's contract rather than from the server's own answers:
counts 0..2**31-1 and times >= 0 (Hypothesis), names up to 100 characters, the Idempotency-Key agreeing with run_id,
'Authorization: Bearer' only, ranking (successful first, then each figure in its direction, then the earlier run),
sorted_total the sum of the *_sorted counts, a verified run id that nobody else may re-post, uploads capped at the
limit exactly."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from course_helpers import Course, mp4_head, post, robokit_payload
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.server.payload import MAX_COUNT, PayloadError, check, default_ranking, figures
from robokit.server.ranking import best_per_student, sort_key
from robokit.server.tokens import TokenError, from_header

pytest_plugins = ["course_fixtures"]


def checked(**fields: Any) -> Any:
    return check({"student": "kim", "project": "A", **fields}, student_required=True, idempotency_key=None)


@settings(max_examples=200, deadline=None)
@given(value=st.integers(-(2**40), 2**40))
def test_counts_are_whole_numbers_from_0_to_2_31_minus_1(value: int) -> None:
    ok = 0 <= value <= 2**31 - 1
    for key in ("red_sorted", "blue_sorted", "failures"):
        if ok:
            assert checked(**{key: value}).figures[key] == value
        else:
            with pytest.raises(PayloadError) as info:
                checked(**{key: value})
            assert info.value.field == key
    assert MAX_COUNT == 2**31 - 1


@settings(max_examples=200, deadline=None)
@given(value=st.floats(-1e9, 1e9, allow_nan=False))
def test_times_are_numbers_at_least_zero(value: float) -> None:
    for key in ("total_time", "sim_time", "wall_time"):
        if value >= 0:
            checked(**{key: value})
        else:
            with pytest.raises(PayloadError, match=key):
                checked(**{key: value})


def test_names_up_to_100_characters() -> None:
    assert checked(student="가" * 100).student == "가" * 100
    with pytest.raises(PayloadError, match="longer than 100"):
        checked(student="가" * 101)


def test_the_idempotency_key_must_agree_with_run_id() -> None:
    data = {"student": "kim", "project": "A", "run_id": "run-1"}
    assert check(data, student_required=True, idempotency_key="run-1").run_id == "run-1"
    assert check({**data, "run_id": None}, student_required=True, idempotency_key="run-2").run_id == "run-2"
    with pytest.raises(PayloadError, match="differs from the payload's run_id"):
        check(data, student_required=True, idempotency_key="run-2")


def test_sorted_total_is_the_sum_and_ranks_first_highest() -> None:
    figs = figures({"red_sorted": 2, "blue_sorted": 3, "failures": 1, "total_time": 9.5,
                    "result": {"green_sorted": 1}})
    assert figs["sorted_total"] == 6
    assert default_ranking(figs) == "-sorted_total,failures,total_time"


@pytest.mark.parametrize("header", ["Token abc", "Basic YWJj", "abc", "Bearer"])
def test_only_bearer_tokens_are_accepted(header: str) -> None:
    with pytest.raises(TokenError):
        from_header(header)


def test_bearer_scheme_in_any_case() -> None:
    assert from_header("Bearer rks_abc") == from_header("bearer rks_abc") == "rks_abc"
    assert from_header(None) is None


def run(pk: int, outcome: str, who: str, received: float, **figs: float) -> Any:
    return SimpleNamespace(pk=pk, outcome=outcome, student_id=None, student_name=who, received_at=received,
                           figures=figs)


def test_ranking_successful_first_then_each_figure_in_its_direction_then_earlier() -> None:
    keys = [("sorted_total", True), ("total_time", False)]
    a = run(1, "succeeded", "a", 1.0, sorted_total=4, total_time=10.0)
    b = run(2, "succeeded", "b", 2.0, sorted_total=4, total_time=8.0)   # as many, faster: before a
    c = run(3, "failed", "c", 3.0, sorted_total=9, total_time=1.0)      # failed: after every success
    d = run(4, "succeeded", "d", 4.0, sorted_total=3, total_time=1.0)   # fewer sorted: after a and b
    e = run(5, "succeeded", "e", 5.0, total_time=0.5)                   # no count: after those with one
    f = run(6, "", "f", 0.5, sorted_total=4, total_time=8.0)            # lesson 08 (no outcome), earlier than b
    order = sorted([a, b, c, d, e, f], key=lambda r: sort_key(r, keys))
    assert [r.student_name for r in order] == ["f", "b", "a", "d", "e", "c"]


def test_each_student_shows_their_best_run() -> None:
    keys = [("sorted_total", True)]
    runs = [run(1, "succeeded", "kim", 1.0, sorted_total=2), run(2, "succeeded", "kim", 2.0, sorted_total=4),
            run(3, "failed", "kim", 3.0, sorted_total=9), run(4, "succeeded", "lee", 4.0, sorted_total=3)]
    best = best_per_student(runs, keys)
    assert [(r.student_name, r.pk) for r in best] == [("kim", 2), ("lee", 4)]


# ------------------------------------------------------------------ against the real server (pytest-django)
@pytest.mark.django_db
def test_an_anonymous_repost_of_a_verified_run_id_is_a_conflict(client: Any, course: Course) -> None:
    payload = robokit_payload(31)
    assert post(client, payload, course.kim_token).status_code == 201
    resp = post(client, payload)  # no token, the class accepts token-less posts
    assert resp.status_code == 409 and resp.json()["field"] == "run_id"
    assert post(client, payload, course.kim_token).status_code == 200  # the owner's repeat is fine


def upload(client: Any, run_id: str, files: dict[str, bytes], token: str | None = None) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    data = {f"file{i}": SimpleUploadedFile(name, content) for i, (name, content) in enumerate(files.items())}
    headers = {"HTTP_AUTHORIZATION": f"Bearer {token}"} if token else {}
    return client.post(f"/api/robotics/result/{run_id}/artifacts/", data=data, **headers)


@pytest.mark.django_db
def test_uploads_are_capped_at_the_limit_exactly_and_only_for_the_runs_owner(
        client: Any, course: Course, settings: Any, tmp_path: Path) -> None:
    settings.MEDIA_ROOT = tmp_path / "media"
    payload = robokit_payload(32)
    post(client, payload, course.kim_token)
    video = mp4_head()
    settings.MAX_VIDEO_BYTES = len(video) + 100
    assert upload(client, payload["run_id"], {"a.mp4": video + b"\x00" * 100}, course.kim_token).status_code == 201
    over = upload(client, payload["run_id"], {"b.mp4": video + b"\x00" * 101}, course.kim_token)
    assert over.status_code == 413
    assert upload(client, payload["run_id"], {"c.mp4": video + b"\x00" * 150}, course.kim_token).status_code == 413
    # docs/server.md (uploads): 401 without a token, 403 with a token that is not allowed
    assert upload(client, payload["run_id"], {"d.mp4": video}).status_code == 401  # verified run: no anonymous files
    assert upload(client, payload["run_id"], {"e.mp4": video}, course.lee_token).status_code == 403


@pytest.mark.django_db
def test_every_chart_is_an_svg_that_runs_nothing_and_no_shared_cache_keeps(client: Any, course: Course) -> None:
    """Charts show a class's and a student's results: served as SVG with a sandboxing Content-Security-Policy (no
    script, nothing fetched) and kept by no shared cache."""
    from course_helpers import PASSWORD
    from course_work import make_assignment

    a = make_assignment(course.room)
    room, kim = course.room.pk, course.kim.pk
    client.login(username="teacher", password=PASSWORD)
    urls = [f"/classes/{room}/assignments/{a.pk}/{k}.svg" for k in ("distribution", "reasons")] + [
        f"/classes/{room}/students/{kim}/{k}.svg" for k in ("timeline", "weekly", "training")]
    for url in urls:
        got = client.get(url)
        assert got.status_code == 200 and got["Content-Type"] == "image/svg+xml", url
        policy = {p.split()[0]: p.split()[1:] for p in got["Content-Security-Policy"].split(";") if p.strip()}
        assert policy["default-src"] == ["'none'"] and "sandbox" in policy, url
        assert set(got["Cache-Control"].replace(" ", "").split(",")) == {"private", "no-cache"}, url
        assert got.content.lstrip().startswith((b"<?xml", b"<svg")), url
