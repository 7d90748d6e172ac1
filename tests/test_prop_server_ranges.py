"""A run's video served in byte ranges, over generated ``Range`` headers (docs/server.md, "Run page": the video is
seekable, byte ranges are served).

Every form of a single byte range (RFC 9110, 14.1.2): ``first-last``, ``first-`` and the suffix ``-n``, inside the
file, past its end, reversed, empty; and headers that are no byte range at all. Expected here from the uploaded bytes:
206 with exactly ``data[first:last + 1]`` (a last past the end is the end; a suffix is the last n bytes) and
``Content-Range: bytes first-last/size``; 416 with ``bytes */size`` when the range starts at or past the end or is
reversed; the whole file, 200 with ``Accept-Ranges: bytes``, for no header or one that is not a byte range.
"""

from __future__ import annotations

from typing import Any

from course_helpers import PASSWORD, mp4_head, post, robokit_payload
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

pytest_plugins = ["course_fixtures"]

PROPS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                 phases=[Phase.explicit, Phase.generate],
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
DATA = mp4_head() + bytes(range(256)) * 3
SIZE = len(DATA)
number = st.one_of(st.sampled_from([0, 1, SIZE - 1, SIZE, SIZE + 1, SIZE + 9]), st.integers(0, SIZE + 20), st.none())
header = st.one_of(st.tuples(number, number).map(lambda p: f"bytes={'' if p[0] is None else p[0]}-"
                                                            f"{'' if p[1] is None else p[1]}"),
                   st.sampled_from(["", "bytes=", "items=0-4", "bytes=1-2,4-5", "bytes=x-3", None]))


def expected(value: str | None) -> tuple[int, bytes, str | None]:
    """(status, body, Content-Range) for a ``Range`` header value, from the bytes."""
    if value is None or not value.startswith("bytes=") or value.count("-") != 1 or "," in value:
        return 200, DATA, None
    first, last = value[len("bytes="):].split("-")
    if not (first.isdigit() or first == "") or not (last.isdigit() or last == "") or not (first or last):
        return 200, DATA, None
    if first:
        start, end = int(first), min(int(last), SIZE - 1) if last else SIZE - 1
    else:  # the last n bytes
        start, end = max(SIZE - int(last), 0), SIZE - 1
    if start >= SIZE or start > end:
        return 416, b"", f"bytes */{SIZE}"
    return 206, DATA[start:end + 1], f"bytes {start}-{end}/{SIZE}"


@PROPS
@given(header)
@example(f"bytes=-{SIZE + 9}")  # a suffix longer than the file: all of it
@example("bytes=-0")
@example(f"bytes={SIZE - 1}-{SIZE + 3}")
def test_every_byte_range_is_the_bytes_it_names(client: Any, course: Any, settings: Any, tmp_path_factory: Any,
                                                value: str | None) -> None:
    from django.core.files.uploadedfile import SimpleUploadedFile

    from robokit.server.models import Artifact

    video = Artifact.objects.filter(kind="video").first()
    if video is None:
        settings.MEDIA_ROOT = tmp_path_factory.mktemp("media")
        payload = robokit_payload(90)
        assert post(client, payload, course.kim_token).status_code == 201
        up = client.post(f"/api/robotics/result/{payload['run_id']}/artifacts/",
                         data={"v": SimpleUploadedFile("run.mp4", DATA)},
                         HTTP_AUTHORIZATION=f"Bearer {course.kim_token}")
        assert up.status_code == 201, up.content
        video = Artifact.objects.get(kind="video")
    assert client.login(username="teacher", password=PASSWORD)
    headers = {} if value is None else {"HTTP_RANGE": value}
    got = client.get(f"/artifacts/{video.pk}/run.mp4", **headers)
    status, body, content_range = expected(value)
    content = b"".join(got.streaming_content) if got.streaming else got.content
    assert (got.status_code, content) == (status, body), value
    assert got.get("Content-Range") == content_range, value
    if status != 416:
        assert got["Content-Type"] == "video/mp4" and int(got["Content-Length"]) == len(body), value
    if status == 200:
        assert got["Accept-Ranges"] == "bytes"
