"""The live page in a real headless Chromium (WebGL through SwiftShader): the cube is drawn where the world has it,
the highlighted state is the trace's, pause holds the clock and step moves it one tick, a key pressed in the page
drives the teleop robot as the scripted key does, and closing the page mid-run changes nothing in the result. The
sensors ticked in the page: the lidar's hits drawn on the wall the world has, each plotted number the trace's reading
at its tick, the camera's image as a run without the page renders it, and the run watched is the run unwatched; a
MuJoCo world drawn at its own link frames."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from live_run import LiveRun, camera_at, final_pose, plain_run, sensors_config
from test_replay_page import chromium

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
SORT = str(ROOT / "configs" / "sort_robot.toml")
DRIVE = str(ROOT / "configs" / "drive_teleop.toml")


def _open(driver: Any, live: LiveRun, seq: int) -> None:
    from selenium.webdriver.support.ui import WebDriverWait

    driver.get(live.view.url)
    shown = "return window.rkLive ? window.rkLive.shown() : -1"
    WebDriverWait(driver, 60).until(lambda d: d.execute_script(shown) >= seq)


def _shown(driver: Any, seq: int) -> None:
    from selenium.webdriver.support.ui import WebDriverWait

    WebDriverWait(driver, 60).until(lambda d: d.execute_script("return window.rkLive.shown()") >= seq)


def _clock(driver: Any) -> float:
    """The sim time the page's clock shows (``t = 1.234 s``), in seconds."""
    from selenium.webdriver.common.by import By

    return float(driver.find_element(By.ID, "live-clock").text.split()[2])


def test_the_page_draws_the_cube_the_state_and_the_clock_and_pause_holds_it() -> None:
    from selenium.webdriver.common.by import By

    live = LiveRun(SORT, 20.0)
    driver = chromium()
    try:
        live.held_at(0)
        _open(driver, live, live.view.publisher.seq)
        live.post("/control", {"action": "speed", "value": "2"})
        live.post("/control", {"action": "resume"})
        going = live.frame_where(lambda f: f["tick"] >= 240)
        _shown(driver, going["seq"])  # the page knows the run goes: its button pauses
        driver.find_element(By.ID, "live-pause").click()  # the page's own button
        held = live.frame_where(lambda f: f["paused"])
        _shown(driver, held["seq"])
        tick = live.sim.world.tick
        assert held["tick"] == tick
        world, client = live.sim.world, live.sim.world.client
        drawn = driver.execute_script(
            "return window.rkLive.groups.map(g => g ? [g.position.x, g.position.y, g.position.z] : null)")
        links = live.view.server.scene["links"]
        for name in ("red_0", "blue_0"):
            i = next(n for n, path in enumerate(links) if path.startswith(name + "/"))
            pos, _ = client.getBasePositionAndOrientation(world.body(name))
            assert drawn[i] == pytest.approx(list(pos), abs=1e-5)
        transitions = [r for r in live.sim.trace if r["kind"] == "transition" and r["machine"] == "pick_place"]
        expected = transitions[-1]["dest_state"] if transitions else "WAIT"
        active = driver.find_element(By.CSS_SELECTOR, "[data-machine='pick_place'] .live-state.active").text
        assert active == expected
        assert _clock(driver) == pytest.approx(tick / 240, abs=6e-4)
        driver.find_element(By.ID, "live-step").click()
        stepped = live.held_at(tick + 1)
        _shown(driver, stepped["seq"])
        assert live.sim.world.tick == tick + 1
        assert _clock(driver) == pytest.approx((tick + 1) / 240, abs=6e-4)
    finally:
        driver.quit()
        live.close()


def test_a_key_pressed_in_the_page_drives_the_teleop_robot_as_the_scripted_key() -> None:
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    held_ticks, max_time, dt = 24, 0.3, 1 / 240
    live = LiveRun(DRIVE, max_time, {"sensors.keys.script": []})
    driver = chromium()
    try:
        live.held_at(0)
        _open(driver, live, live.view.publisher.seq)
        driver.find_element(By.TAG_NAME, "h1").click()
        ActionChains(driver).key_down(Keys.ARROW_UP).perform()
        assert live.view.keys.wait_held({"up"}, 60)
        for k in range(1, held_ticks + 1):
            driver.find_element(By.ID, "live-step").click()
            live.held_at(k)
        ActionChains(driver).key_up(Keys.ARROW_UP).perform()
        assert live.view.keys.wait_held(set(), 60)
        result, _ = live.finish()
        from selenium.webdriver.support.ui import WebDriverWait

        WebDriverWait(driver, 60).until(lambda d: d.find_element(By.ID, "live-outcome").text)
        assert driver.find_element(By.ID, "live-outcome").text == f"{result.outcome}: {result.reason}"
        pos, orn = live.sim.world.client.getBasePositionAndOrientation(live.sim.world.body("robot"))
    finally:
        driver.quit()
        live.close()
    scripted = final_pose(DRIVE, max_time, {"sensors.keys.script": [{"at": 0.0, "keys": ["up"],
                                                                      "hold": (held_ticks - 0.5) * dt}]})
    assert (pos, orn) == scripted


def test_closing_the_page_mid_run_changes_nothing_in_the_result() -> None:
    expected, expected_trace = plain_run(SORT, 2.0)
    live = LiveRun(SORT, 2.0)
    driver = chromium()
    try:
        live.held_at(0)
        _open(driver, live, live.view.publisher.seq)
        live.post("/control", {"action": "speed", "value": "2"})
        live.post("/control", {"action": "resume"})
        live.frame_where(lambda f: f["tick"] >= 120)
        driver.quit()  # the page goes away while the run goes on
        result, trace = live.finish()
    finally:
        live.close()
    assert (result.outcome, result.reason, result.ticks, result.result) == \
        (expected.outcome, expected.reason, expected.ticks, expected.result)
    assert trace == expected_trace


IMAGE_PIXELS = """
const img = document.querySelector("[data-sensor='cam'] img");
if (!img.complete || !img.naturalWidth) return null;
const c = document.createElement("canvas");
c.width = img.naturalWidth; c.height = img.naturalHeight;
const ctx = c.getContext("2d");
ctx.drawImage(img, 0, 0);
return [c.width, c.height, Array.from(ctx.getImageData(0, 0, c.width, c.height).data)];"""
"""The camera image the page shows: its width, height and RGBA pixels (null until it is decoded)."""


def test_the_sensors_picked_in_the_page_are_drawn_as_the_world_and_the_trace_have_them(tmp_path: Path) -> None:
    import math

    import numpy as np
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    config = sensors_config(tmp_path)
    live = LiveRun(config, 1.0)
    driver = chromium()
    try:
        live.held_at(0)
        _open(driver, live, live.view.publisher.seq)
        for name in ("lidar", "touch", "cam"):  # the page's own check boxes
            driver.find_element(By.CSS_SELECTOR, f"#live-picks input[value='{name}']").click()
        WebDriverWait(driver, 60).until(lambda d: live.view.feed.wanted == {"lidar", "touch", "cam"})
        live.post("/control", {"action": "step", "value": "60"})
        live.held_at(60)
        for _ in range(6):  # six ticks the page is shown one by one: six points on the plot
            live.step()
            _shown(driver, live.view.publisher.seq)
        stamp = live.sim.world.tick - 1  # the record behaviour read every sensor in the last tick that ran

        # the plot: every point is the trace's reading at its tick
        series = driver.execute_script("return rkLive.views.touch.series()")
        traced = {r["tick"]: r["value"] for r in live.sim.trace if r["kind"] == "reading" and r["component"] == "touch"}
        points = series["normal_force"]
        assert len(points) >= 6 and points[-1][0] == stamp
        assert any(value > 0 for _, value in points)  # the box has landed: a force to plot
        for tick, value in points:
            assert value == traced[tick]["normal_force"]
        assert [v for _, v in series["points"]] == [float(traced[t]["points"]) for t, _ in series["points"]]
        driver.find_element(By.CSS_SELECTOR, "[data-sensor='touch'] [data-field='in_contact']").click()
        assert set(driver.execute_script("return rkLive.views.touch.shown()")) == \
            set(series) - {"in_contact"}  # the student took one number off the plot

        # the scan: each drawn hit lies where one of the lidar's rays meets the wall the world has
        assert driver.execute_script("return rkLive.views.lidar.tick()") == stamp
        hits = np.asarray(driver.execute_script("return rkLive.views.lidar.hits()")).reshape(-1, 3)
        world = live.sim.world
        lo, hi = world.body_aabb("wall")
        lidar = live.sim.components["lidar"]
        origin = np.asarray(live.view.publisher.latest()["sensors"]["lidar"]["origin"])  # type: ignore[index]
        _, orn = world.client.getBasePositionAndOrientation(world.body("robot"))
        yaw = world.client.getEulerFromQuaternion(orn)[2]
        angles = lidar.angle_min + lidar.angle_inc * np.arange(lidar.config.rays) + yaw
        assert len(hits) >= 5
        for x, y, z in hits:
            assert x == pytest.approx(lo[0], abs=1e-3)  # the face towards the robot
            assert lo[1] <= y <= hi[1] and lo[2] <= z <= hi[2]
            heading = math.atan2(y - origin[1], x - origin[0])
            assert np.min(np.abs(np.angle(np.exp(1j * (angles - heading))))) < 2e-3  # along one of its rays

        # the camera: the image shown is the camera's image at its tick, rendered again by a run without the page
        shown = "return rkLive.views.cam.tick()"
        WebDriverWait(driver, 60).until(lambda d: d.execute_script(shown) == stamp)
        pixels = WebDriverWait(driver, 60).until(lambda d: d.execute_script(IMAGE_PIXELS))
        result, trace = live.finish()  # the page still watching every sensor
    finally:
        driver.quit()
        live.close()
    width, height, data = pixels
    drawn = np.asarray(data, np.uint8).reshape(height, width, 4)[:, :, :3].astype(int)
    expected = camera_at(config, stamp).astype(int)
    assert drawn.shape == expected.shape
    assert np.abs(drawn - expected).mean() < 1.5  # JPEG at quality 90 (the image at tick 0 is 11 levels away)
    plain, plain_trace = plain_run(config, 1.0)  # watched or not, the run is the same bit for bit
    assert (result.outcome, result.reason, result.ticks, result.result) == \
        (plain.outcome, plain.reason, plain.ticks, plain.result)
    assert trace == plain_trace


def test_a_mujoco_world_is_drawn_where_the_world_has_it_with_its_lidar_scan(tmp_path: Path) -> None:
    import numpy as np
    from selenium.webdriver.common.by import By

    config = sensors_config(tmp_path, camera=False, contact=False)
    mujoco = {"world.engine": "mujoco"}
    live = LiveRun(config, 1.0, mujoco, sensors=("lidar",))  # ticked from the start, as --live-sensors does
    driver = chromium()
    try:
        live.held_at(0)
        _open(driver, live, live.view.publisher.seq)
        assert driver.find_element(By.CSS_SELECTOR, "#live-picks input[value='lidar']").is_selected()
        live.post("/control", {"action": "step", "value": "80"})
        held = live.held_at(80)
        _shown(driver, held["seq"])
        drawn = driver.execute_script(
            "return window.rkLive.groups.map(g => g ? [g.position.x, g.position.y, g.position.z, g.quaternion.x,"
            " g.quaternion.y, g.quaternion.z, g.quaternion.w] : null)")
        world, links = live.sim.world, live.view.server.scene["links"]
        for path in ("box/link0", "robot/base_link", "robot/left_wheel_link"):
            body, link = path.split("/")
            index = -1 if link in ("link0", "base_link") else world.link(body, link)
            pos, orn = world.pose(body, index)  # the MuJoCo world's own link frame
            assert drawn[links.index(path)] == pytest.approx([*pos, *orn], abs=1e-5)
        hits = np.asarray(driver.execute_script("return rkLive.views.lidar.hits()")).reshape(-1, 3)
        lo, hi = world.body_aabb("wall")
        assert len(hits) >= 5 and hits[:, 0] == pytest.approx(lo[0], abs=1e-3)
        assert np.all((hits[:, 1] >= lo[1] - 1e-3) & (hits[:, 1] <= hi[1] + 1e-3))
    finally:
        driver.quit()
        live.close()
