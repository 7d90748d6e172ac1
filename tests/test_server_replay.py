"""The 3D replay on the server's run page: the run's files uploaded with ``upload_artifacts`` include
``replay.json`` (what ``robokit view`` embeds, made from the record); the server checks it and the run page draws it
with three.js, served from robokit's package data. What the slow test expects on the canvas comes from the
record through pybullet's own forward kinematics, not from the replay's data."""

from __future__ import annotations

import base64
import json
import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from course_helpers import Course, post, robokit_payload
from server_proc import Server, free_port, robokit
from test_server_run_media import SCENE, _class_with_student

from robokit.cli import main
from robokit.record.format import find_run
from robokit.report.artifact_upload import find_artifacts, replay_file

pytest_plugins = ["course_fixtures"]
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
PASSWORD = "media-teacher-pass"


@pytest.fixture(scope="module")
def record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder of a real run of the small arm scene (1 s, pose log at 30 Hz)."""
    folder = tmp_path_factory.mktemp("run")
    (folder / "scene.toml").write_text(SCENE, encoding="utf-8")
    assert main(["run", str(folder / "scene.toml"), "--quiet", "--set", f"report.local.dir={folder / 'results'}"]) == 0
    return find_run("last", folder / "results").folder


def test_the_replay_is_made_from_the_record_once_and_uploaded_with_the_other_files(record: Path) -> None:
    made = replay_file(record)
    assert made == record / "replay.json" and "replay.json" in dict(find_artifacts(record))
    data = json.loads(made.read_text(encoding="utf-8"))
    samples = len(np.load(record / "poses.npz")["t"])
    t = np.frombuffer(base64.b64decode(data["t"]), np.float32)
    assert len(t) == samples and len(data["links"]) >= 8  # the plane, the box, the arm's base and its 7 links
    assert {link.split("/")[0] for link in data["links"]} == {"plane", "box", "kuka"}
    stamp = made.stat().st_mtime_ns
    assert replay_file(record) == made and made.stat().st_mtime_ns == stamp  # not made again


def _upload(client: Any, run_id: str, name: str, content: bytes, token: str) -> Any:
    from django.core.files.uploadedfile import SimpleUploadedFile

    return client.post(f"/api/robotics/result/{run_id}/artifacts/", data={"f": SimpleUploadedFile(name, content)},
                       HTTP_AUTHORIZATION=f"Bearer {token}")


@pytest.mark.django_db
def test_the_server_keeps_a_replay_and_its_run_page_loads_it(client: Any, course: Course, settings: Any,
                                                             tmp_path: Path, record: Path) -> None:
    settings.MEDIA_ROOT = tmp_path / "media"
    payload = robokit_payload(31)
    assert post(client, payload, course.kim_token).status_code == 201
    run = payload["run_id"]
    good = (record / "replay.json").read_bytes() if (record / "replay.json").is_file() else \
        replay_file(record).read_bytes()  # type: ignore[union-attr]
    data = json.loads(good)
    short = {**data, "poses": base64.b64encode(base64.b64decode(data["poses"])[:-28]).decode()}  # one link short
    bad_frame = {**data, "frames": [{"camera": "c", "t": 0, "png": "javascript:alert(1)"}]}
    for name, content, words in [("replay.json", b"[1, 2]", "not a JSON object"),
                                 ("replay.json", json.dumps(short).encode(), "'poses' holds"),
                                 ("replay.json", json.dumps(bad_frame).encode(), "PNG data URIs"),
                                 ("other.json", good, "replay.json are accepted")]:
        refused = _upload(client, run, name, content, course.kim_token)
        assert refused.status_code == 400 and words in refused.json()["error"], refused.content
    assert _upload(client, run, "replay.json", good, course.kim_token).status_code == 201

    client.force_login(course.teacher)
    page = client.get(f"/runs/{run}/").content.decode()
    box = re.search(r"<div id='rk-replay' data-src='([^']+)' data-script='([^']+)'>", page)
    assert box is not None, page
    assert b"".join(client.get(box.group(1)).streaming_content) == good
    viewer = re.search(r'<script src="(/replay/viewer\.js)" defer></script><script src="([^"]+replay_boot\.js)"',
                       page)
    assert viewer is not None
    served = b"".join(client.get(viewer.group(1)).streaming_content)
    assert b"three.js" in served[:300] and len(served) > 100_000
    script = b"".join(client.get(box.group(2)).streaming_content)
    assert script.startswith(b"// robokit's replay")


@pytest.mark.django_db
def test_a_run_that_uploads_its_files_sends_its_replay(live_server: Any, course: Course, settings: Any,
                                                       tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The pose log is written before the result is sent when the reporter uploads the record, so the upload right
    after the result carries the replay (it used to be written after delivery)."""
    from robokit.server.models import Artifact

    settings.MEDIA_ROOT = tmp_path / "media"
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ROBOKIT_TOKEN", course.kim_token)
    (tmp_path / "scene.toml").write_text(SCENE, encoding="utf-8")
    assert main(["run", "scene.toml", "--quiet", "--report-url", live_server.url + "/api/robotics/result/",
                 "--set", "report.http.upload_artifacts=true", "--project", "A"]) == 0
    rec = find_run("last", tmp_path / "results")
    stored = {a.name: a for a in Artifact.objects.filter(result__run_id=rec.run_id)}
    assert {"replay.json", "trace.jsonl"} <= set(stored)
    kept = Path(settings.MEDIA_ROOT) / stored["replay.json"].path
    assert kept.read_bytes() == (rec.folder / "replay.json").read_bytes()


def _driver(tmp_path: Path) -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                "--disable-background-networking", "--window-size=1280,1000", "--force-device-scale-factor=1",
                f"--user-data-dir={tmp_path / 'chrome'}"):
        opts.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)


def arm_points(rec_folder: Path, sample: int) -> list[list[float]]:
    """World positions of the KUKA's link frames at one pose sample, by pybullet's own forward kinematics."""
    import pybullet as p
    import pybullet_data

    poses = np.load(rec_folder / "poses.npz")
    header = json.loads((rec_folder / "trace.jsonl").read_text().splitlines()[0])
    client = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
        base = poses["base/kuka"][sample]  # the base's centre of mass, as pybullet gives it and takes it back
        arm = p.loadURDF("kuka_iiwa/model.urdf", useFixedBase=True, physicsClientId=client)
        p.resetBasePositionAndOrientation(arm, base[:3].tolist(), base[3:].tolist(), physicsClientId=client)
        names = {p.getJointInfo(arm, j, physicsClientId=client)[1].decode(): j
                 for j in range(p.getNumJoints(arm, physicsClientId=client))}
        for name, q in zip(header["bodies"]["kuka"]["joints"], poses["joints/kuka"][sample], strict=True):
            p.resetJointState(arm, names[name], float(q), physicsClientId=client)
        return [list(p.getLinkState(arm, j, computeForwardKinematics=True, physicsClientId=client)[4])
                for j in range(1, 7)]
    finally:
        p.disconnect(client)


@pytest.mark.slow
@pytest.mark.skipif(not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
                    reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")
def test_the_served_run_page_draws_the_uploaded_replay(tmp_path: Path) -> None:
    import cv2
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import WebDriverWait

    data, token = _class_with_student(tmp_path)
    work = tmp_path / "student"
    work.mkdir()
    (work / "scene.toml").write_text(SCENE, encoding="utf-8")
    server = Server(data, free_port()).start()
    driver = None
    try:
        ran = robokit("run", "scene.toml", "--json", "--report-url", f"{server.url}/api/robotics/result/",
                      "--set", "report.http.upload_artifacts=true", "--project", "A", cwd=work,
                      env={"ROBOKIT_TOKEN": token})
        run_id = json.loads(ran.stdout)["run_id"]
        assert re.search(r"artifacts: (\d+)/\1 uploaded", ran.stderr), ran.stderr
        rec = find_run(run_id, work / "results")

        driver = _driver(tmp_path)
        wait = WebDriverWait(driver, 60)
        driver.get(f"{server.url}/accounts/login/")
        driver.find_element(By.NAME, "username").send_keys("teacher")
        driver.find_element(By.NAME, "password").send_keys(PASSWORD)
        driver.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "1반")))
        driver.get(f"{server.url}/runs/{run_id}/")
        wait.until(lambda d: d.execute_script("return !!window.rkReplay"))
        pane = driver.find_element(By.ID, "rk-pane")
        driver.execute_script("arguments[0].scrollIntoView(); window.scrollBy(0, -10);", pane)

        def shot() -> np.ndarray:
            driver.execute_script("rkReplay.viewer.render();")
            decoded = cv2.imdecode(np.frombuffer(driver.get_screenshot_as_png(), np.uint8), cv2.IMREAD_COLOR)
            assert decoded is not None
            return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)

        def project(point: list[float]) -> tuple[int, int]:
            x, y = driver.execute_script("return rkReplay.project(...arguments)", *[float(v) for v in point])
            return int(round(x)), int(round(y))

        arm = "rkReplay.viewer.scene.getObjectByName('robokit').children.filter(g => g.name.startsWith('kuka/'))"
        driver.execute_script("rkReplay.show(0)")
        with_arm = shot()
        driver.execute_script(arm + ".forEach(g => { g.visible = false; });")
        without = shot()
        driver.execute_script(arm + ".forEach(g => { g.visible = true; }); rkReplay.show(0);")
        canvas = driver.execute_script("return rkReplay.viewer.renderer.domElement.getBoundingClientRect()")
        left, top, right, bottom = (canvas[k] for k in ("left", "top", "right", "bottom"))
        inside = [(col, row) for col, row in map(project, arm_points(rec.folder, 0))
                  if left + 3 <= col < right - 3 and top + 3 <= row < bottom - 3]
        assert len(inside) == 6, inside  # the default view frames the whole scene, the arm's top included
        drawn = sum(int(np.abs(with_arm[row - 2:row + 3, col - 2:col + 3].astype(int)
                                - without[row - 2:row + 3, col - 2:col + 3]).sum() > 100) for col, row in inside)
        assert drawn >= 5, f"the arm is drawn at {drawn} of its 6 link frames"
        box = project(np.load(rec.folder / "poses.npz")["base/box"][0, :3].tolist())  # the red box's centre
        patch = with_arm[box[1] - 2:box[1] + 3, box[0] - 2:box[0] + 3].astype(int)
        assert (patch[:, :, 0] > patch[:, :, 1] + 60).all(), patch[2, 2]
        shot_path = tmp_path / "server-replay.png"  # the artifact: the served page's replay
        driver.save_screenshot(str(shot_path))
        assert shot_path.stat().st_size > 10_000
        severe = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE" and "favicon" not in e["message"]]
        assert not severe, severe  # no script refused by the page's policy, no failed fetch
    finally:
        if driver is not None:
            driver.quit()
        server.stop()
        shutil.rmtree(data / "media", ignore_errors=True)
