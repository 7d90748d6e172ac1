"""The live page in a real headless Chromium (WebGL through SwiftShader): the cube is drawn where the world has it,
the highlighted state is the trace's, pause holds the clock and step moves it one tick, a key pressed in the page
drives the teleop robot as the scripted key does, and closing the page mid-run changes nothing in the result."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from live_run import LiveRun, final_pose, plain_run
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
