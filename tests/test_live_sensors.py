"""The sensors a page picks, over HTTP (no browser): a frame carries each picked sensor's latest reading as the run
made it. The oracles: the trace's ``reading`` records (the numbers at that tick), the wall the world has (the lidar's
hits), the camera sensor's own image (the JPEG served), and a frame nobody asked sensors for (no payload)."""

from __future__ import annotations

import urllib.error
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import pytest
from live_run import WAIT, WALL_FACE, LiveRun, plain_run, pose_at, sensors_config


def test_the_sensors_a_page_asks_for_reach_it_as_the_run_made_them(tmp_path: Path) -> None:
    live = LiveRun(sensors_config(tmp_path), 1.0)
    try:
        assert "sensors" not in live.run_to(2)  # no page asked: no sensor payload is built
        with pytest.raises(urllib.error.HTTPError) as refused:
            live.get("/events?sensors=touch,sonar")
        assert refused.value.code == 400 and "'sonar'" in refused.value.read().decode()
        with pytest.raises(urllib.error.HTTPError) as missing:
            live.get("/camera/touch")
        assert missing.value.code == 404
        # a page's event stream asking for three sensors (its headers come once the ask is registered)
        with urllib.request.urlopen(live.view.url + "events?sensors=lidar,touch,cam", timeout=WAIT):
            live.post("/control", {"action": "step", "value": "78"})
            frame = live.held_at(80)
        sensors = frame["sensors"]
        assert {s["tick"] for s in sensors.values()} == {79}  # the last tick that ran read every sensor
        readings = {r["component"]: r["value"] for r in live.sim.trace
                    if r["kind"] == "reading" and r["tick"] == 79}
        touch = sensors["touch"]["values"]
        assert touch["normal_force"] == readings["touch"]["normal_force"] > 0
        assert (touch["in_contact"], touch["points"]) == (float(readings["touch"]["in_contact"]),
                                                          float(readings["touch"]["points"]))
        scan = sensors["lidar"]
        points = np.asarray(scan["points"]).reshape(-1, 3)
        hits = points[[c == "1" for c in scan["hit"]]]
        lo, hi = live.sim.world.body_aabb("wall")
        assert len(hits) >= 5
        assert hits[:, 0] == pytest.approx(WALL_FACE, abs=1e-3)  # on the wall's face, within its extent
        assert np.all((hits[:, 1] >= lo[1] - 1e-3) & (hits[:, 1] <= hi[1] + 1e-3))
        body, headers = live.get("/camera/cam")
        assert headers["X-Robokit-Tick"] == "79"
        served = cv2.cvtColor(cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        own = live.sim.scheduler.slots["cam"].value.rgb  # the camera sensor's image at tick 79
        assert served.shape == own.shape
        # JPEG at quality 90: within 1.5 levels on average (the image at tick 0, the box higher, is 11 levels away)
        assert np.abs(served.astype(int) - own.astype(int)).mean() < 1.5
    finally:
        live.close()


@pytest.mark.slow
def test_a_mujoco_world_is_drawn_as_it_runs_and_ends_as_it_does_without_the_page(tmp_path: Path) -> None:
    # no contact sensor: on MuJoCo a contact's normal force in its first tick is read before MuJoCo has solved it
    # (memory no solve has written yet: 0.0, 2e-309 or 4e252 for this box, by what the process did before), so
    # two runs in one process need not agree on it, with or without a page
    config = sensors_config(tmp_path, camera=False, contact=False)
    mujoco = {"world.engine": "mujoco"}
    expected, expected_trace = plain_run(config, 0.5, mujoco)
    live = LiveRun(config, 0.5, mujoco, sensors=("lidar",))
    try:
        frame = live.run_to(80)
        links = live.view.server.scene["links"]
        box = links.index("box/link0")
        assert frame["poses"][7 * box:7 * box + 7] == pytest.approx(pose_at(config, 80, mujoco, "box"), abs=2e-6)
        assert frame["poses"][7 * box + 2] == pytest.approx(0.05, abs=2e-3)  # landed: half its 0.1 m above the floor
        assert {"robot/left_wheel_link", "robot/lidar_link"} <= set(links)  # the robot's links, each drawn
        scan = frame["sensors"]["lidar"]
        hits = np.asarray(scan["points"]).reshape(-1, 3)[[c == "1" for c in scan["hit"]]]
        assert len(hits) >= 5 and hits[:, 0] == pytest.approx(WALL_FACE, abs=1e-3)
        result, trace = live.finish()
    finally:
        live.close()
    assert (result.outcome, result.reason, result.ticks, result.result) == \
        (expected.outcome, expected.reason, expected.ticks, expected.result)
    assert trace == expected_trace
