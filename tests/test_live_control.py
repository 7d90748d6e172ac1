"""The live view without a browser: its state endpoint shows the world as it is, pause / step / speed / resume leave
the run bit for bit what it is without the live view, and a key sent from the page drives the teleop robot as the
same key scripted does. The oracles: a run of the same config and seed with no live view, and the world itself."""

from __future__ import annotations

from pathlib import Path

import pytest
from live_run import LiveRun, final_pose, plain_run

ROOT = Path(__file__).resolve().parent.parent
PICK = str(ROOT / "configs" / "pick_place.toml")
DRIVE = str(ROOT / "configs" / "drive_teleop.toml")


@pytest.mark.slow
def test_paused_stepped_and_resumed_run_is_the_uninterrupted_run_and_the_state_shows_the_world() -> None:
    expected, expected_trace = plain_run(PICK, 1.2)
    live = LiveRun(PICK, 1.2)
    try:
        live.held_at(0)
        for k in range(1, 4):
            assert live.step() == k
            assert live.sim.world.tick == k  # held: the loop waits at tick k, no further
        live.post("/control", {"action": "speed", "value": "1"})  # real time: the pause lands long before the end
        live.post("/control", {"action": "resume"})
        live.frame_where(lambda f: f["tick"] >= 150)  # past the first transitions after the start
        live.post("/control", {"action": "pause"})
        held = live.frame_where(lambda f: f["paused"])["tick"]
        state = live.state()
        assert state["tick"] == held == live.sim.world.tick and state["paused"]
        links = live.view.server.scene["links"]
        client, world = live.sim.world.client, live.sim.world
        for name in ("cube",):  # a box's base frame is its centre of mass: the world's own pose
            i = next(n for n, path in enumerate(links) if path.startswith(name + "/"))
            pos, orn = client.getBasePositionAndOrientation(world.body(name))
            assert state["poses"][7 * i:7 * i + 7] == pytest.approx([*pos, *orn], abs=2e-6)
        last = [r for r in live.sim.trace if r["kind"] == "transition" and r["machine"] == "behaviour"]
        assert state["states"]["behaviour"] == (last[-1]["dest_state"] if last else "WAIT")
        assert live.step() == held + 1
        result, trace = live.finish()
    finally:
        live.close()
    assert (result.outcome, result.reason, result.ticks, result.sim_time) == \
        (expected.outcome, expected.reason, expected.ticks, expected.sim_time)
    assert result.result == expected.result
    assert trace == expected_trace
    assert live.view.publisher.latest()["outcome"]["outcome"] == expected.outcome  # type: ignore[index]


def test_a_key_from_the_page_drives_the_teleop_robot_as_the_scripted_key_does() -> None:
    held_ticks, max_time = 48, 0.4
    dt = 1 / 240
    no_script = {"sensors.keys.script": []}
    live = LiveRun(DRIVE, max_time, no_script)
    try:
        live.held_at(0)
        live.post("/key", {"key": "up", "down": True})
        for _ in range(held_ticks):
            live.step()
        live.post("/key", {"key": "up", "down": False})
        live.finish()
        client, bid = live.sim.world.client, live.sim.world.body("robot")
        pos_live, orn_live = client.getBasePositionAndOrientation(bid)
    finally:
        live.close()
    scripted = final_pose(DRIVE, max_time, {"sensors.keys.script": [{"at": 0.0, "keys": ["up"],
                                                                      "hold": (held_ticks - 0.5) * dt}]})
    still = final_pose(DRIVE, max_time, no_script)
    assert (pos_live, orn_live) == scripted  # bit for bit
    moved = ((pos_live[0] - still[0][0]) ** 2 + (pos_live[1] - still[0][1]) ** 2) ** 0.5
    assert moved > 0.005, f"the key moved the robot {moved:.4f} m"


def test_a_live_view_bound_beyond_loopback_answers_only_with_its_token() -> None:
    import json
    import urllib.error
    import urllib.request

    from robokit.live import LiveView

    view = LiveView("0.0.0.0", 0, announce=False)  # noqa: S104 - the point of the test
    try:
        token = view.server.token
        assert token and view.url.endswith(f"/?token={token}")
        base = f"http://127.0.0.1:{view.server.port}"
        for path in ("/state", "/state?token=wrong", "/"):
            with pytest.raises(urllib.error.HTTPError) as refused:
                urllib.request.urlopen(base + path, timeout=30)
            assert refused.value.code == 403
        with urllib.request.urlopen(f"{base}/state?token={token}", timeout=30) as reply:
            assert json.loads(reply.read()) is None  # no run has started: no frame yet
    finally:
        view.close(grace=0)
    loopback = LiveView("127.0.0.1", 0, announce=False)
    try:
        assert loopback.server.token is None
    finally:
        loopback.close(grace=0)


@pytest.mark.parametrize("value, ticks", [("", 1), ("1", 1), ("3", 3), ("240", 240)])
def test_a_step_lets_exactly_the_asked_ticks_through_then_holds(value: str, ticks: int) -> None:
    from robokit.live.publisher import Control

    control = Control(paused=True)
    control.apply("step", value)
    held = [False]
    passed = 0
    while passed <= ticks:  # each gate is one tick's start; the hold's callback marks the run held
        control.gate(0.0, lambda: held[0], lambda: held.__setitem__(0, True))
        if held[0]:
            break
        passed += 1
    assert passed == ticks and control.state()["paused"]


@pytest.mark.parametrize("value", ["0", "-2", "1.5", "two"])
def test_a_step_of_no_whole_positive_number_of_ticks_is_refused(value: str) -> None:
    from robokit.live.publisher import Control

    with pytest.raises(ValueError, match="whole number of ticks"):
        Control(paused=True).apply("step", value)
