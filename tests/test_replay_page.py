"""The run page's 3D replay in a real headless Chromium (WebGL through SwiftShader): it draws the arm where the
record puts it, the cubes end in their bins, a click on a state moves the time there. What the test expects comes
from the record through pybullet itself (forward kinematics of the logged joints), not from the page's data."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robokit.record.format import find_run
from robokit.record.scene import choose_view, rebuild
from robokit.record.video import Renderer

ROOT = Path(__file__).resolve().parent.parent
MB = 1024 * 1024


@pytest.fixture(scope="module")
def sort_page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("replay")
    for args in (("run", str(ROOT / "configs" / "sort_robot.toml"), "--quiet"),
                 ("view", "last", "-o", "sort.html")):
        proc = subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                              cwd=folder, timeout=600)
        assert proc.returncode == 0, proc.stderr
    return folder


def arm_points(rec_folder: Path, sample: int) -> list[list[float]]:
    """World positions of the Panda's link frames at one pose sample, by pybullet's own forward kinematics."""
    import pybullet as p
    import pybullet_data

    poses = np.load(rec_folder / "poses.npz")
    header = json.loads((rec_folder / "trace.jsonl").read_text().splitlines()[0])
    client = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
        base = poses["base/panda"][sample]
        arm = p.loadURDF("franka_panda/panda.urdf", base[:3].tolist(), base[3:].tolist(), useFixedBase=True,
                         physicsClientId=client)
        names = {p.getJointInfo(arm, j, physicsClientId=client)[1].decode(): j
                 for j in range(p.getNumJoints(arm, physicsClientId=client))}
        for name, q in zip(header["bodies"]["panda"]["joints"], poses["joints/panda"][sample], strict=True):
            p.resetJointState(arm, names[name], float(q), physicsClientId=client)
        return [list(p.getLinkState(arm, j, computeForwardKinematics=True, physicsClientId=client)[4])
                for j in range(1, 8)]
    finally:
        p.disconnect(client)


def chromium() -> Any:
    """Headless Chromium drawing WebGL with SwiftShader, 1280 x 1000 CSS pixels at scale 1."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
                "--disable-background-networking", "--window-size=1280,1000", "--force-device-scale-factor=1"):
        opts.add_argument(arg)
    return webdriver.Chrome(service=Service(shutil.which("chromedriver") or "/usr/bin/chromedriver"), options=opts)


def screenshot(driver: Any) -> np.ndarray:
    """The page as an RGB array, drawn again first."""
    import cv2

    driver.execute_script("rkReplay.viewer.render();")
    decoded = cv2.imdecode(np.frombuffer(driver.get_screenshot_as_png(), np.uint8), cv2.IMREAD_COLOR)
    assert decoded is not None
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)


def colour_mask(shot: np.ndarray, colour: str) -> np.ndarray:
    r, g, b = (shot[:, :, k].astype(int) for k in range(3))
    if colour == "red":
        return (r > 140) & (g < 90) & (b < 90)
    return (b > 140) & (r < 90) & (g < 110)


@pytest.mark.slow
def test_the_replay_draws_the_arm_the_cubes_in_their_bins_and_follows_state_clicks(sort_page: Path) -> None:
    import cv2
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    page = sort_page / "sort.html"
    assert page.stat().st_size <= 5 * MB  # video, plots, diagrams and the replay with the Panda's meshes
    rec = find_run("last", sort_page / "results")
    poses = np.load(rec.folder / "poses.npz")
    driver = chromium()
    shot_path = sort_page / "replay.png"
    try:
        driver.get(page.as_uri())
        WebDriverWait(driver, 30).until(lambda d: d.execute_script("return !!window.rkReplay"))
        pane = driver.find_element(By.ID, "rk-pane")
        driver.execute_script("arguments[0].scrollIntoView(); window.scrollBy(0, -10);", pane)

        def shot() -> np.ndarray:
            return screenshot(driver)

        def project(point: list[float]) -> tuple[int, int]:
            x, y = driver.execute_script("return rkReplay.project(...arguments)", *[float(v) for v in point])
            return int(round(x)), int(round(y))

        # 0. the replay opens on the video's default view: every point is where the video's camera puts it, in
        # units of the picture's height from its middle (same eye, target and vertical field of view; the pane is
        # wider than the video, so it shows more at the sides)
        canvas_box = driver.execute_script("return rkReplay.viewer.renderer.domElement.getBoundingClientRect()")
        with rebuild(rec) as scene:
            view = choose_view(scene, None, 4 / 3)
            video = Renderer(scene, view, (480, 360))
            for point in [list(view.target), *arm_points(rec.folder, 0), [1.25, 0.5, 0.0], [-0.25, -0.5, 0.0]]:
                col, row = driver.execute_script("return rkReplay.project(...arguments)", *map(float, point))
                page_at = ((col - canvas_box["left"] - canvas_box["width"] / 2) / canvas_box["height"],
                           (row - canvas_box["top"] - canvas_box["height"] / 2) / canvas_box["height"])
                vcol, vrow = video.project(tuple(point))  # type: ignore[arg-type]
                assert page_at == pytest.approx(((vcol - 240) / 360, (vrow - 180) / 360), abs=0.01), point

        # 1. the arm: pixels where pybullet puts its links change when the arm is hidden
        driver.execute_script("rkReplay.show(0)")
        with_arm = shot()
        driver.execute_script("rkReplay.viewer.scene.getObjectByName('robokit').children"
                              ".filter(g => g.name.startsWith('panda/')).forEach(g => { g.visible = false; });")
        without = shot()
        driver.execute_script("rkReplay.viewer.scene.getObjectByName('robokit').children"
                              ".forEach(g => { g.visible = true; }); rkReplay.show(0);")
        drawn = 0
        points = arm_points(rec.folder, 0)
        for point in points:
            col, row = project(point)
            a, b = with_arm[row - 2:row + 3, col - 2:col + 3].astype(int), without[row - 2:row + 3, col - 2:col + 3]
            drawn += int(np.abs(a - b).sum() > 100)
        assert drawn >= len(points) - 1, f"the arm is drawn at {drawn} of its {len(points)} link frames"
        # the pointer over the arm's third link names it
        from selenium.webdriver.common.action_chains import ActionChains

        canvas = driver.execute_script("return rkReplay.viewer.renderer.domElement")
        rect = driver.execute_script("return arguments[0].getBoundingClientRect()", canvas)
        col, row = project(points[3])
        ActionChains(driver).move_to_element_with_offset(
            canvas, int(col - rect["left"] - rect["width"] / 2), int(row - rect["top"] - rect["height"] / 2)).perform()
        assert driver.find_element(By.ID, "rk-hover").text.startswith("panda/panda_link")

        # 2. the end: each colour's cubes are inside its bin's region of the picture, not at the start
        def in_bin(picture: np.ndarray, colour: str) -> int:
            centre = poses[f"base/{colour}_bin"][-1, :3]
            corners = [project([centre[0] + dx, centre[1] + dy, centre[2] + dz]) for dx in (-0.075, 0.075)
                       for dy in (-0.075, 0.075) for dz in (0.0, 0.05)]  # a 0.15 m tray (0.3 m at scale 0.5)
            cols, rows = zip(*corners, strict=True)
            return int(colour_mask(picture, colour)[min(rows):max(rows) + 1, min(cols):max(cols) + 1].sum())

        # The replay opens on the video's view, from behind the arm, which stands in front of the blue bin at the
        # end: the bins are looked at with the arm hidden (the arm was checked above); the artifact shows it.
        hide_arm = ("rkReplay.viewer.scene.getObjectByName('robokit').children"
                    ".filter(g => g.name.startsWith('panda/')).forEach(g => { g.visible = false; });")
        driver.execute_script(hide_arm)
        start = {c: in_bin(shot(), c) for c in ("red", "blue")}
        driver.execute_script("rkReplay.show(rkReplay.duration)")
        driver.execute_script(hide_arm)
        bins_shot = shot()
        end = {c: in_bin(bins_shot, c) for c in ("red", "blue")}
        driver.execute_script("rkReplay.viewer.scene.getObjectByName('robokit').children"
                              ".forEach(g => { g.visible = true; });")
        end_shot = shot()
        assert rec.result["result"]["red_sorted"] == rec.result["result"]["blue_sorted"] == 2
        assert end["red"] > 40 and end["blue"] > 40, end
        assert start["red"] < end["red"] / 4 and start["blue"] < end["blue"] / 4, (start, end)
        cv2.imwrite(str(shot_path), cv2.cvtColor(end_shot, cv2.COLOR_RGB2BGR))

        # 3. a click on a state of the timeline moves the time to where that stay began (from the trace)
        lines = (rec.folder / "trace.jsonl").read_text().splitlines()[1:]
        changes = [json.loads(line) for line in lines if json.loads(line).get("kind") == "transition"]
        lifts = [e["t"] for e in changes if e["machine"] == "pick_place" and e["dest_state"] == "LIFT"]
        spans = driver.find_elements(By.CSS_SELECTOR, ".rk-row:nth-child(2) .rk-span")
        lift = [s for s in spans if str(s.get_attribute("title")).startswith("LIFT ")][1]
        driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", lift)
        driver.execute_script("arguments[0].click();", lift)
        assert driver.execute_script("return rkReplay.time()") == pytest.approx(lifts[1], abs=1e-6)
        assert "pick_place: LIFT" in driver.find_element(By.ID, "rk-clock").text
    finally:
        driver.quit()
    assert shot_path.stat().st_size > 10_000  # the artifact: the replay at the end of the run


TALL = """
[world]
max_time = 0.5
seed = 4

[bodies.plane]
urdf = "plane.urdf"
position = [0, 0, 0]

[robots.kuka]
urdf = "kuka_iiwa/model.urdf"
position = [0, 0, 0]
fixed_base = true
"""
"""A 1.3 m arm alone on the floor: nothing else widens the scene's box."""


def kuka_box(rec_folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """The KUKA's world bounding box (all links) at the first pose sample, from pybullet itself."""
    import pybullet as p
    import pybullet_data

    poses = np.load(rec_folder / "poses.npz")
    header = json.loads((rec_folder / "trace.jsonl").read_text().splitlines()[0])
    client = p.connect(p.DIRECT)
    try:
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=client)
        arm = p.loadURDF("kuka_iiwa/model.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=client)
        names = {p.getJointInfo(arm, j, physicsClientId=client)[1].decode(): j
                 for j in range(p.getNumJoints(arm, physicsClientId=client))}
        for name, q in zip(header["bodies"]["kuka"]["joints"], poses["joints/kuka"][0], strict=True):
            p.resetJointState(arm, names[name], float(q), physicsClientId=client)
        links = range(-1, p.getNumJoints(arm, physicsClientId=client))
        boxes = [p.getAABB(arm, j, physicsClientId=client) for j in links]
        return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
    finally:
        p.disconnect(client)


@pytest.mark.slow
def test_the_default_view_shows_a_tall_robot_from_its_base_to_its_top(tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    (tmp_path / "tall.toml").write_text(TALL, encoding="utf-8")
    for args in (("run", "tall.toml", "--quiet"), ("view", "last", "-o", "tall.html")):
        proc = subprocess.run([sys.executable, "-m", "robokit.cli", *args], capture_output=True, text=True,
                              cwd=tmp_path, timeout=300)
        assert proc.returncode == 0, proc.stderr
    lo, hi = kuka_box(find_run("last", tmp_path / "results").folder)
    assert hi[2] - lo[2] > 1.2  # the arm stands upright: a tall scene
    driver = chromium()
    try:
        driver.get((tmp_path / "tall.html").as_uri())
        WebDriverWait(driver, 30).until(lambda d: d.execute_script("return !!window.rkReplay"))
        pane = driver.find_element(By.ID, "rk-pane")
        driver.execute_script("arguments[0].scrollIntoView(); window.scrollBy(0, -10);", pane)

        def placement() -> tuple[Any, list[Any]]:
            rect = driver.execute_script("return rkReplay.viewer.renderer.domElement.getBoundingClientRect()")
            return rect, [driver.execute_script("return rkReplay.project(...arguments)", float(x), float(y), float(z))
                          for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]

        def arm(visible: bool) -> None:
            driver.execute_script("rkReplay.viewer.scene.getObjectByName('robokit').children"
                                  ".filter(g => g.name.startsWith('kuka/'))"
                                  ".forEach(g => { g.visible = arguments[0]; });",
                                  visible)

        for _ in range(5):  # two shots of one layout: a page still settling (a scroll bar, a resize) is shot again
            rect, corners = placement()
            with_arm = screenshot(driver)
            arm(False)
            without = screenshot(driver)
            arm(True)
            if placement() == (rect, corners):
                break
        else:
            raise AssertionError("the page's layout kept changing")
        cols, rows = (np.array(v) for v in zip(*corners, strict=True))
        left, top, right, bottom = cols.min(), rows.min(), cols.max(), rows.max()
        # the arm's whole box is inside the canvas, and not a speck in it
        assert rect["left"] <= left and right <= rect["left"] + rect["width"], (cols, rect)
        assert rect["top"] <= top and bottom <= rect["top"] + rect["height"], (rows, rect)
        assert bottom - top > rect["height"] / 3, (rows, rect)
        drawn = np.abs(with_arm.astype(int) - without.astype(int)).sum(axis=2) > 60
        canvas = np.zeros_like(drawn)  # only the 3D view: the page's video below may still be loading (a spinner)
        x0, y0 = int(rect["left"]), int(rect["top"])
        canvas[y0:y0 + int(rect["height"]), x0:x0 + int(rect["width"])] = True
        drawn &= canvas
        r0, r1, c0, c1 = int(top), int(bottom) + 1, int(left), int(right) + 1
        band = max(3, (r1 - r0) // 10)
        assert drawn[r0:r0 + band, c0:c1].sum() > 20, "the arm's top is not drawn"
        assert drawn[r1 - band:r1, c0:c1].sum() > 20, "the arm's base is not drawn"
        assert drawn[:, :c0].sum() + drawn[:, c1:].sum() + drawn[:r0].sum() + drawn[r1:].sum() < 0.02 * drawn.sum()
    finally:
        driver.quit()
