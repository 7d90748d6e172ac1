"""A run's video and 3D replay on the course server: ``robokit run --video`` renders before the result is sent, so
``upload_artifacts`` uploads the video with the run; the run page serves what was uploaded."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import pytest
from server_proc import Server, free_port, robokit, teacher_session

PASSWORD = "media-teacher-pass"
SCENE = """
[world]
max_time = 1.0
seed = 4

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[bodies.box]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0.5, 0, 0.5]
rgba = [1, 0, 0, 1]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true

[actuators.joints]
type = "joint_control"
body = "kuka"
mode = "position"
[actuators.joints.sine.lbr_iiwa_joint_1]
amplitude = 1.0
frequency_hz = 0.5
"""


def _class_with_student(tmp_path: Path) -> tuple[Path, str]:
    """A server data folder with a teacher, class 1반 and one student; the student's token."""
    data = tmp_path / "srv"
    robokit("serve", "--data", str(data), "--create-teacher", "teacher", cwd=tmp_path,
            env={"ROBOKIT_TEACHER_PASSWORD": PASSWORD})
    robokit("manage", "--data", str(data), "create_class", "1반", "--teacher", "teacher", cwd=tmp_path)
    added = robokit("manage", "--data", str(data), "add_students", "1반", "김민준", cwd=tmp_path)
    return data, added.stdout.strip().split("\t")[1]


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@pytest.mark.slow
def test_run_with_video_uploads_the_video_with_the_result(tmp_path: Path) -> None:
    data, token = _class_with_student(tmp_path)
    work = tmp_path / "student"
    work.mkdir()
    (work / "scene.toml").write_text(SCENE, encoding="utf-8")
    server = Server(data, free_port()).start()
    try:
        url = f"{server.url}/api/robotics/result/"
        ran = robokit("run", "scene.toml", "--json", "--video", "clip.mp4", "--report-url", url,
                      "--set", "report.http.upload_artifacts=true", "--project", "A", cwd=work,
                      env={"ROBOKIT_TOKEN": token})
        run_id = json.loads(ran.stdout)["run_id"]
        uploaded = re.search(r"artifacts: (\d+)/(\d+) uploaded", ran.stderr)
        assert uploaded is not None and uploaded.group(1) == uploaded.group(2), ran.stderr
        local = (work / "clip.mp4").read_bytes()
        assert local[4:8] == b"ftyp"

        session = teacher_session(server.url, "teacher", PASSWORD)
        page = session.get(f"{server.url}/runs/{run_id}/", timeout=30).text
        src = re.search(r'<video id="video-1"[^>]* src="([^"]+clip\.mp4)"', page)
        assert src is not None, page[:2000]
        served = session.get(server.url + src.group(1), timeout=30)
        assert served.status_code == 200 and _sha(served.content) == _sha(local)
    finally:
        server.stop()


def test_the_video_a_run_folder_notes_is_uploaded_wherever_it_was_written(tmp_path: Path) -> None:
    from robokit.report.artifact_upload import find_artifacts

    run = tmp_path / "results" / "r1"
    run.mkdir(parents=True)
    (run / "trace.jsonl").write_text("{}\n", encoding="utf-8")
    clip = tmp_path / "elsewhere" / "sort.mp4"
    clip.parent.mkdir()
    clip.write_bytes(b"\0\0\0\x18ftypisom")
    (run / "video.json").write_text(json.dumps({"path": str(clip)}), encoding="utf-8")
    assert dict(find_artifacts(run)) == {"sort.mp4": clip, "trace.jsonl": run / "trace.jsonl"}
    clip.unlink()  # gone since: nothing to send for it
    assert dict(find_artifacts(run)) == {"trace.jsonl": run / "trace.jsonl"}
