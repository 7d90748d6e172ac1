"""The walk-through of docs/server.md, "Course work: from an assignment to grades", run with its own commands on
a real server with its queue worker: an assignment with a deadline, three students (one refused with a one-line
message naming the key, one late), the official evaluation, the board, charts and dashboard in headless Chromium
(screenshots checked for what the charts must show), and the grade export."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import requests
from course_procs import PASSWORD, CourseServer, setup_class
from course_work import OFFICIAL, changed
from server_proc import teacher_session

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
    reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")]
BLUE, RED, LINE = (0x4C, 0x72, 0xB0), (0xC4, 0x4E, 0x52), (0x1F, 0x77, 0xB4)


def doc_commands() -> list[list[str]]:
    """The ``robokit`` commands of the walk-through's ``sh`` blocks, continuation lines joined."""
    text = (ROOT / "docs" / "server.md").read_text(encoding="utf-8")
    section = text[text.index("## Course work: from an assignment to grades"):text.index("## The API")]
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", section, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            if line.startswith("robokit "):
                commands.append(shlex.split(line, comments=True))
    return commands


def run(cmd: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "robokit.cli", *cmd[1:]], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def pixels_near(png: bytes, colour: tuple[int, int, int], tolerance: int = 12) -> int:
    """How many pixels of a screenshot are within ``tolerance`` of ``colour`` (per channel)."""
    import matplotlib.image as mpimg
    import numpy as np

    rgb = (mpimg.imread(io.BytesIO(png), format="png")[..., :3] * 255).round().astype(int)
    return int((np.abs(rgb - np.array(colour)) <= tolerance).all(axis=-1).sum())


def _driver(tmp_path: Path) -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-dev-shm-usage", "--window-size=1280,1400", f"--user-data-dir={tmp_path / 'chrome'}"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def _chart(driver: Any, element_id: str, tmp_path: Path) -> bytes:
    from selenium.webdriver.common.by import By

    img = driver.find_element(By.ID, element_id)
    assert driver.execute_script("return arguments[0].complete && arguments[0].naturalWidth", img) > 100
    png: bytes = img.screenshot_as_png
    (tmp_path / f"{element_id}.png").write_bytes(png)
    return png


def _screenshot(driver: Any, tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    driver.save_screenshot(str(path))
    if os.environ.get("ROBOKIT_SCREENSHOTS"):
        shutil.copy(path, ROOT / os.environ["ROBOKIT_SCREENSHOTS"] / name)


def test_docs_walkthrough_assignment_to_grades(tmp_path: Path) -> None:
    server = CourseServer(tmp_path / "data", workers=1)
    tokens = setup_class(server, ["김민준", "이서연", "박지호"])
    (create,), (submit,) = ([c for c in doc_commands() if c[1] == verb] for verb in ("manage", "submit"))
    create = [*create[:2], "--data", str(server.data), *create[2:]]
    (tmp_path / "official.toml").write_text(OFFICIAL, encoding="utf-8")
    made = run(create, tmp_path, server.env)
    assert made.returncode == 0 and "20 official seeds" in made.stdout, made.stderr
    server.start()
    try:
        def student(name: str, config: str) -> subprocess.CompletedProcess[str]:
            home = tmp_path / name
            home.mkdir()
            (home / submit[3]).write_text(config, encoding="utf-8")
            cmd = [*submit[:submit.index("--url") + 1], server.url + "/"]
            return run(cmd, home, {**server.env, "ROBOKIT_TOKEN": tokens[name]})

        kim = student("김민준", changed(OFFICIAL, duration="0.4"))
        assert kim.returncode == 0 and kim.stdout.startswith("submitted: submission"), kim.stderr
        lee = student("이서연", changed(OFFICIAL, mass="2.0"))
        assert lee.returncode == 2 and lee.stderr.count("\n") == 1
        assert lee.stderr.startswith("robokit: error: mine.toml: bodies.box.mass: students may not change")
        due = create.index("--due") + 1
        assert run([*create[:due], "2026-11-01T00:00", *create[due + 1:]], tmp_path, server.env).returncode == 0
        park = student("박지호", changed(OFFICIAL, max_time="0.2"))
        assert park.returncode == 0 and park.stdout.startswith("submitted (late): submission"), park.stderr
        done = "SELECT count(*) FROM course_submission WHERE status = 'done'"
        server.wait_for("both submissions evaluated", lambda: server.query(done)[0][0] == 2, 900)
        log = "\n".join(json.dumps({"steps": 500 * i, "return": i - 8.0, "success_rate": i / 20}) for i in range(21))
        resp = requests.post(f"{server.url}/api/robotics/training/", timeout=30, json={"name": "ARS", "log": log},
                             headers={"Authorization": f"Bearer {tokens['김민준']}"})
        assert resp.status_code == 201
        _browse(server, tmp_path)
        grades = teacher_session(server.url, "teacher", PASSWORD).get(f"{server.url}/classes/1/grades.csv",
                                                                       timeout=60)
    finally:
        server.stop()
    rows = {r["student"]: r for r in csv.DictReader(io.StringIO(grades.content.decode("utf-8-sig")))}
    assert set(rows) == {"김민준", "이서연", "박지호"}
    assert (rows["김민준"]["낙하 실험: success_rate"], rows["김민준"]["낙하 실험: late"]) == ("1.0000", "")
    assert (rows["박지호"]["낙하 실험: success_rate"], rows["박지호"]["낙하 실험: late"]) == ("0.0000", "late")
    assert (rows["이서연"]["낙하 실험: success_rate"], rows["이서연"]["낙하 실험: submissions"]) == ("", "0")
    assert rows["김민준"]["낙하 실험: wilson_low"] == f"{20 / (20 + 1.959963984540054 ** 2):.4f}"  # n/(n+z^2)


def _browse(server: CourseServer, tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import WebDriverWait

    driver = _driver(tmp_path)
    try:
        wait = WebDriverWait(driver, 60)
        driver.get(f"{server.url}/accounts/login/")
        driver.find_element(By.NAME, "username").send_keys("teacher")
        driver.find_element(By.NAME, "password").send_keys(PASSWORD)
        driver.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "1반"))).click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "낙하 실험"))).click()
        wait.until(ec.presence_of_element_located((By.CSS_SELECTOR, "#official-board table")))
        names = [e.text for e in driver.find_elements(By.CSS_SELECTOR, "#official-board td.student")]
        assert names == ["김민준", "박지호"]  # 20/20 before 0/20; 이서연 was refused
        board = driver.find_element(By.ID, "official-board").text
        assert "1.00" in board and "0.00" in board and "late" in board
        assert "not submitted" in driver.find_element(By.ID, "who").text
        # The charts' content: the histogram has bars (blue) and the reasons chart a bar for max_time (red).
        assert pixels_near(_chart(driver, "chart-distribution", tmp_path), BLUE) > 500
        assert pixels_near(_chart(driver, "chart-reasons", tmp_path), RED) > 500
        _screenshot(driver, tmp_path, "server-assignment.png")
        driver.find_element(By.LINK_TEXT, "김민준").click()
        wait.until(ec.presence_of_element_located((By.ID, "chart-training")))
        assert pixels_near(_chart(driver, "chart-training", tmp_path), LINE) > 100  # the training curves
        assert pixels_near(_chart(driver, "chart-timeline", tmp_path), BLUE) > 50  # the official result
        _screenshot(driver, tmp_path, "server-dashboard.png")
    finally:
        driver.quit()
