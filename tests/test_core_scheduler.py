"""The tick loop: order inside a tick, rates, lazy sensors, events, stop conditions, errors, interrupts."""

from __future__ import annotations

import pytest
from core_probes import CALLS, ProbePlugin, scene

from robokit.testing import make_sim

PLUGINS = (ProbePlugin(),)


@pytest.fixture(autouse=True)
def _clear_calls():
    CALLS.clear()
    yield
    CALLS.clear()


def sim_of(config, **kw):
    return make_sim(config, extra_plugins=PLUGINS, **kw)


def test_order_inside_a_tick_is_sensor_behaviour_command_actuator() -> None:
    cfg = scene(push=1.0)
    cfg["sensors"]["height"]["eager"] = True
    with sim_of(cfg) as sim:
        sim.step(1)
    assert [c[0] for c in CALLS] == ["sensor", "behaviour", "command", "actuator"]
    assert all(tick == 0 for *_, tick in CALLS)


def test_lazy_sensor_is_computed_only_when_read_and_due() -> None:
    with sim_of(scene(reads=["height"])) as sim:
        sim.step(24)
        assert sim.readings.computed("height") == 6  # 60 Hz of 240 Hz: ticks 0, 4, ..., 20
    with sim_of(scene(reads=[])) as sim:
        sim.step(24)
        assert sim.readings.computed("height") == 0  # nobody looked: nothing computed


def test_reading_between_periods_is_the_last_one_with_its_stamp() -> None:
    with sim_of(scene(reads=["height"])) as sim:
        sim.step(6)
        assert sim.readings.stamp("height") == 4
        assert [t for kind, _, t in CALLS if kind == "sensor"] == [0, 4]


def test_behaviour_rate() -> None:
    cfg = scene()
    cfg["behaviour"]["rate_hz"] = 30
    with sim_of(cfg) as sim:
        sim.step(80)
    assert [t for kind, _, t in CALLS if kind == "behaviour"] == list(range(0, 80, 8))


def test_actuator_pushes_body_through_physics() -> None:
    with sim_of(scene(push=20.0)) as sim:  # 20 N up on a ~0.5 kg ball beats gravity
        sim.step(120)
        assert sim.world.pose("ball")[0][2] > 0.3


def test_stop_on_outcome_and_max_time() -> None:
    with sim_of(scene(finish_at=0.5)) as sim:
        res = sim.run()
    assert (res.outcome, res.reason, res.ticks) == ("succeeded", "probe done", 121)
    assert res.exit_code == 0
    with sim_of(scene()) as sim:
        res = sim.run(max_time=0.25)
    assert res.outcome == "aborted" and "max_time 0.25 s" in res.reason
    assert res.ticks == 60 and res.exit_code == 1


def test_plugin_error_ends_run_with_error_and_keeps_partial_result() -> None:
    with sim_of(scene(fail_at=0.1)) as sim:
        res = sim.run()
    assert res.outcome == "error"
    assert "probe" in res.reason and "RuntimeError: probe failure" in res.reason
    assert res.result["steps"] == 25
    assert res.exit_code == 3


def test_sigint_stops_cleanly_at_a_tick_boundary_and_keeps_the_result() -> None:
    with sim_of(scene(sigint_at=0.5)) as sim:
        res = sim.run()
    assert res.outcome == "aborted" and res.interrupted
    assert "SIGINT" in res.reason
    assert res.exit_code == 130
    assert res.result["steps"] == 121  # the tick that saw the signal finished, then the loop stopped


def test_timed_force_event_fires_at_its_tick() -> None:
    cfg = scene()
    cfg["events"] = [{"at": 0.5, "type": "force", "body": "ball", "force": [50, 0, 0], "duration": 0.05}]
    with sim_of(cfg) as sim:
        sim.step(120)
        assert sim.world.pose("ball")[0][0] == pytest.approx(0.0, abs=1e-6)
        sim.step(60)
        assert sim.world.pose("ball")[0][0] > 0.05
    events = [r for r in sim.trace if r["kind"] == "event"]
    assert len(events) == 1 and events[0]["tick"] == 120


def test_set_pose_and_remove_events() -> None:
    cfg = scene()
    cfg["events"] = [{"at": 0.1, "type": "set_pose", "body": "ball", "position": [1, 2, 0.05]},
                     {"at": 0.2, "type": "remove", "body": "ball"}]
    with sim_of(cfg) as sim:
        sim.step(30)
        assert sim.world.pose("ball")[0][:2] == pytest.approx((1, 2), abs=1e-3)
        sim.step(30)
        assert not sim.world.has_body("ball")


def test_run_until() -> None:
    with sim_of(scene(push=20.0)) as sim:
        assert sim.run_until(lambda s: s.world.pose("ball")[0][2] > 0.2, max_ticks=500)
        assert 0 < sim.world.tick < 500
        assert not sim.run_until(lambda s: False, max_ticks=10)
