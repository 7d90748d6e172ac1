"""The student's journey, as README.md tells it: the set-up command (a fresh virtual environment, ``pip install .``,
the main job), then every command of "See what a run did" (results, video, a still, plots, the run page, frames,
run-then-render), then the page they open: in headless Chromium, the video plays and the plots and state diagrams
are there.

The commands are read from the README's fenced blocks (tests/journey.py) and run one by one with bash, as pasted;
nothing is re-typed here. The fresh environment gets exactly what ``pip install .`` pulls in (no extras): a command
that needs a library the base install lacks fails here as it would for the student.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from journey import ROOT, activated, blocks_under, fresh_checkout, ok, sh, shell_lines

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
README = ROOT / "README.md"

pytestmark = [pytest.mark.slow, pytest.mark.timeout(3600)]


def _driver(tmp_path: Path):  # type: ignore[no-untyped-def]
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                "--disable-background-networking",
                "--disable-dev-shm-usage", "--window-size=1280,1000", f"--user-data-dir={tmp_path / 'chrome'}",
                "--autoplay-policy=no-user-gesture-required"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


@pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                    reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")
def test_readme_set_up_then_see_what_a_run_did(tmp_path: Path) -> None:
    repo, env = fresh_checkout(tmp_path)
    [setup, _tests] = blocks_under(README, "Set-up")
    [first] = shell_lines(setup)
    assert first.startswith("python3 -m venv .venv") and "pip install ." in first  # the install is the journey's start
    out = ok(sh(first, repo, env), first)
    assert "outcome: succeeded" in out

    [see] = blocks_under(README, "See what a run did")
    student = activated(repo, env)
    lines = shell_lines(see)
    assert len(lines) >= 8
    for line in lines:
        ok(sh(line, repo, student), line)

    runs = sorted((repo / "results").iterdir(), key=lambda p: p.stat().st_mtime)
    assert len(runs) == 4  # set-up, "See what a run did" (sort, camera demo, sort --video)
    results = [json.loads((run / "result.json").read_text()) for run in runs]
    assert [r["outcome"] for r in results] == ["succeeded"] * 4
    assert list((runs[2]).rglob("*.png"))  # --save-frames: the camera's frames
    for name in ("sort.mp4", "end.png", "sort.html"):
        assert (repo / name).stat().st_size > 1000, name
    assert list((runs[1] / "plots").glob("*.png"))

    page = (repo / "sort.html").resolve()
    driver = _driver(tmp_path)
    try:
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import WebDriverWait

        driver.get(page.as_uri())
        wait = WebDriverWait(driver, 120)
        assert driver.find_element(By.CSS_SELECTOR, "h1 .outcome").text == "succeeded"
        video = driver.find_element(By.ID, "run-video")
        wait.until(lambda d: d.execute_script("return arguments[0].readyState >= 1", video))  # metadata decoded
        duration = driver.execute_script("return arguments[0].duration", video)
        assert duration == pytest.approx(results[1]["sim_time"], abs=0.25)  # the whole run, in sim seconds
        driver.execute_script("arguments[0].currentTime = arguments[1]", video, duration / 2)
        wait.until(lambda d: d.execute_script("return arguments[0].readyState >= 2", video))  # a frame to show
        imgs = driver.find_elements(By.CSS_SELECTOR, "figure img")
        assert imgs and all(driver.execute_script("return arguments[0].naturalWidth", i) > 100 for i in imgs)
        assert driver.find_elements(By.CSS_SELECTOR, "svg")  # the state diagrams, inline
        # the 3D replay, drawn with the viewer the wheel ships (robokit/data/three.min.js): a canvas of the pane's size
        wait.until(lambda d: d.execute_script("return !!window.rkReplay"))
        canvas = driver.execute_script("return rkReplay.viewer.renderer.domElement.getBoundingClientRect()")
        assert canvas["width"] > 600 and canvas["height"] > 400, canvas
    finally:
        driver.quit()
