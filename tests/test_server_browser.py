"""A real browser (Debian's headless Chromium through Selenium) against ``robokit serve``: the teacher logs in, opens
the leaderboard and a run's page, and sees the video and the figures; Korean names are drawn as Hangul.

Set ``ROBOKIT_SCREENSHOTS=docs`` to write the screenshots into docs/ (as the ones there were made).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import pytest
import requests
from server_proc import Server, free_port, robokit

from robokit.core.result import RunResult
from robokit.report.reporting import build_payload

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
PASSWORD = "browser-teacher-pass"
SCRIPT_NAME = "<script>alert('x')</script>"
ROOT = Path(__file__).resolve().parents[1]


def _payload(i: int, student: str, red: int, blue: int, failures: int, total: float) -> dict[str, Any]:
    objects = [{"colour": c, "detected_position": [0.4 + 0.05 * k, 0.1 * (-1) ** k, 0.025],
                "detection_error": 0.0002 * (k + 1), "bin": f"{c}_bin", "attempts": 1, "outcome": "sorted"}
               for k, c in enumerate(["red"] * red + ["blue"] * blue)]
    r = RunResult(run_id=f"b0000000-0000-4000-8000-{i:012d}", robokit_version="0.1.0",
                  config="configs/sort_robot.toml", behaviour="sort", seed=i, outcome="succeeded",
                  reason=f"sorted {red + blue} object(s)", ticks=1910, sim_time=total, wall_time=1.3,
                  started_at="2026-11-23T10:00:00+00:00",
                  result={"red_sorted": red, "blue_sorted": blue, "failures": failures, "total_time": total,
                          "camera_frames": 5, "objects": objects})
    return build_payload(r, student=student, project="A")


def _video(path: Path) -> Path:
    """A real 2-second H.264 MP4 (imageio-ffmpeg's bundled ffmpeg), a moving square."""
    import imageio_ffmpeg
    import numpy as np

    writer = imageio_ffmpeg.write_frames(str(path), (160, 128), fps=12, codec="libx264", pix_fmt_out="yuv420p",
                                         output_params=["-movflags", "+faststart"])
    writer.send(None)
    for k in range(24):
        frame = np.full((128, 160, 3), 235, np.uint8)
        frame[40:80, 5 * k:5 * k + 40] = (200, 30, 30)
        writer.send(frame.tobytes())
    writer.close()
    return path


def _plot(path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4, 2.6), dpi=80)
    ax.plot([0, 1, 2, 3, 4, 5, 6, 7], [0, 0.2, 0.5, 0.45, 0.7, 0.9, 0.85, 1.0], marker="o")
    ax.set_xlabel("sim time (s)")
    ax.set_ylabel("gripper z (m)")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _trace() -> bytes:
    states = [(0.0, "CLEAR_VIEW", "LOOK", "view_clear"), (0.0, "LOOK", "PICK_PLACE", "found"),
              (2.1, "PICK_PLACE", "LOOK", "placed"), (2.1, "LOOK", "PICK_PLACE", "found"),
              (4.0, "PICK_PLACE", "LOOK", "placed"), (4.0, "LOOK", "PICK_PLACE", "found"),
              (6.0, "PICK_PLACE", "LOOK", "placed"), (6.0, "LOOK", "PICK_PLACE", "found"),
              (7.9, "PICK_PLACE", "LOOK", "placed"), (7.95, "LOOK", "DONE", "clear")]
    lines = [f'{{"kind": "transition", "t": {t}, "machine": "behaviour", "source_state": "{a}", '
             f'"dest_state": "{b}", "trigger": "{trig}"}}' for t, a, b, trig in states]
    return ("\n".join(lines) + "\n").encode()


def _driver(tmp_path: Path) -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-dev-shm-usage", "--window-size=1280,1000", f"--user-data-dir={tmp_path / 'chrome'}"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def _student_pk(driver: Any, name: str) -> str:
    from selenium.webdriver.common.by import By

    href: str = driver.find_element(By.LINK_TEXT, name).get_attribute("href")
    return href.rstrip("/").rsplit("/", 1)[-1]


def _platform_fonts(driver: Any, selector: str) -> list[dict[str, Any]]:
    """The fonts Chromium used for the text inside ``selector`` (family name and glyph count per font)."""
    driver.execute_cdp_cmd("DOM.enable", {})
    driver.execute_cdp_cmd("CSS.enable", {})
    root = driver.execute_cdp_cmd("DOM.getDocument", {})["root"]["nodeId"]
    node = driver.execute_cdp_cmd("DOM.querySelector", {"nodeId": root, "selector": selector})["nodeId"]
    assert node, selector
    fonts: list[dict[str, Any]] = driver.execute_cdp_cmd("CSS.getPlatformFontsForNode", {"nodeId": node})["fonts"]
    return fonts


def _save(driver: Any, tmp_path: Path, name: str) -> Path:
    path = tmp_path / name
    driver.save_screenshot(str(path))
    target = os.environ.get("ROBOKIT_SCREENSHOTS")
    if target:
        shutil.copy(path, ROOT / target / name)
    return path


@pytest.mark.slow
@pytest.mark.skipif(not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)),
                    reason="needs Debian's chromium and chromium-driver (installed by .ci/run)")
def test_teacher_sees_leaderboard_run_video_and_hangul(tmp_path: Path) -> None:
    from selenium.common.exceptions import NoAlertPresentException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as ec
    from selenium.webdriver.support.ui import WebDriverWait

    data, port = tmp_path / "srv", free_port()
    robokit("serve", "--data", str(data), "--create-teacher", "teacher", cwd=tmp_path,
            env={"ROBOKIT_TEACHER_PASSWORD": PASSWORD})
    robokit("manage", "--data", str(data), "create_class", "1반", "--teacher", "teacher", cwd=tmp_path)
    out = robokit("manage", "--data", str(data), "add_students", "1반", "김민준", "이서연", SCRIPT_NAME,
                  cwd=tmp_path).stdout
    tokens = dict(line.split("\t") for line in out.strip().splitlines())
    server = Server(data, port).start()
    driver = None
    try:
        api = f"{server.url}/api/robotics/result/"
        runs = [("김민준", 1, 2, 2, 0, 7.96), ("김민준", 2, 2, 1, 1, 9.4), ("이서연", 3, 2, 2, 1, 8.7),
                (SCRIPT_NAME, 4, 1, 1, 2, 12.1)]
        for name, i, red, blue, fail, total in runs:
            resp = requests.post(api, json=_payload(i, "anyone", red, blue, fail, total), timeout=30,
                                 headers={"Authorization": f"Bearer {tokens[name]}"})
            assert resp.status_code == 201, resp.text
        best = _payload(1, "", 0, 0, 0, 0)["run_id"]
        files = {"run.mp4": _video(tmp_path / "run.mp4").read_bytes(),
                 "gripper_z.png": _plot(tmp_path / "gripper_z.png").read_bytes(), "trace.jsonl": _trace()}
        up = requests.post(f"{api}{best}/artifacts/", files={f"f{k}": (n, b) for k, (n, b) in enumerate(files.items())},
                           headers={"Authorization": f"Bearer {tokens['김민준']}"}, timeout=60)
        assert up.status_code == 201, up.text

        driver = _driver(tmp_path)
        wait = WebDriverWait(driver, 60)
        driver.get(f"{server.url}/accounts/login/")
        driver.find_element(By.NAME, "username").send_keys("teacher")
        driver.find_element(By.NAME, "password").send_keys(PASSWORD)
        driver.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "1반"))).click()
        wait.until(ec.presence_of_element_located((By.LINK_TEXT, "A"))).click()
        wait.until(ec.presence_of_element_located((By.CSS_SELECTOR, "#students table.board")))
        names = [e.text for e in driver.find_elements(By.CSS_SELECTOR, "#students td.student")]
        assert names == ["김민준", "이서연", SCRIPT_NAME]  # best first; the script is shown as its text
        with pytest.raises(NoAlertPresentException):
            driver.switch_to.alert.text  # noqa: B018 - nothing ran
        # Hangul is drawn with a Korean font, not as "tofu" boxes: Chromium itself says which platform font drew
        # the name's glyphs (DevTools protocol, CSS.getPlatformFontsForNode), and two names differ in pixels.
        for name in ("김민준", "이서연"):
            fonts = _platform_fonts(driver, f'#students td.student a[href$="/{_student_pk(driver, name)}/"]')
            assert fonts and all("nanum" in f["familyName"].lower() or "cjk" in f["familyName"].lower()
                                 for f in fonts), fonts
            assert sum(f["glyphCount"] for f in fonts) == 3
        kim, seo = (driver.find_element(By.LINK_TEXT, n) for n in ("김민준", "이서연"))
        assert kim.screenshot_as_png != seo.screenshot_as_png
        _save(driver, tmp_path, "server-leaderboard.png")

        driver.find_element(By.CSS_SELECTOR, f'#students a[href="/runs/{best}/"]').click()
        video = wait.until(ec.presence_of_element_located((By.TAG_NAME, "video")))
        assert video.get_attribute("src").endswith("/run.mp4")
        wait.until(lambda d: d.execute_script("return arguments[0].readyState >= 1", video))  # metadata loaded
        assert driver.execute_script("return arguments[0].duration", video) == pytest.approx(2.0, abs=0.2)
        figures = {row.find_element(By.TAG_NAME, "th").text: row.find_element(By.TAG_NAME, "td").text
                   for row in driver.find_elements(By.CSS_SELECTOR, "table.figures tr")}
        assert figures["red_sorted"] == "2" and figures["blue_sorted"] == "2" and figures["sorted_total"] == "4"
        assert figures["total_time"] == "7.96"
        plot = driver.find_element(By.CSS_SELECTOR, ".plots img")
        wait.until(lambda d: d.execute_script("return arguments[0].complete && arguments[0].naturalWidth", plot))
        png = files["gripper_z.png"]
        assert driver.execute_script("return arguments[0].naturalWidth", plot) == int.from_bytes(png[16:20], "big")
        assert len(driver.find_elements(By.CSS_SELECTOR, ".timeline .seg")) == 10
        assert len(driver.find_elements(By.CSS_SELECTOR, "table.objects tbody tr")) == 4
        driver.execute_script("arguments[0].currentTime = 1.0", video)
        wait.until(lambda d: d.execute_script("return arguments[0].readyState >= 2", video))
        height = driver.execute_script("return document.documentElement.scrollHeight")
        driver.set_window_size(1280, min(int(height) + 40, 4000))  # the whole page in one screenshot
        _save(driver, tmp_path, "server-run.png")
    finally:
        if driver is not None:
            driver.quit()
        server.stop()
    assert not any(t in server.log for t in tokens.values())
