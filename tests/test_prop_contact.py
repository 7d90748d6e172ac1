"""The ``contact`` sensor over every combination of its filters, against a plain filter of the world's contacts.

One settled scene -- a box on the floor with another stacked on it, a box alone, the diffbot on its wheels and caster
-- and, per generated config (body, link, other, other_link, ignore, min_force), a contact sensor set up on it. The
expected reading is the body's every contact point (the world's, unfiltered) filtered in plain Python by the
config's rules (docs of ``ContactConfig``); which pairs touch at all is known from how the scene was built. Config
mistakes (an unknown name, ``other_link`` without ``other``, ``ignore`` with ``other``) must be a ConfigError at
the key that holds the mistake.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from robokit_plugins.contact import ContactConfig, ContactSensor

from robokit.components import SetupContext
from robokit.errors import ConfigError
from robokit.testing import PLANE, make_sim

SCENE = {
    "bodies": {"plane": PLANE,
               "a": {"shape": "box", "size": [0.2, 0.2, 0.2], "mass": 2.0, "position": [0, 0, 0.1]},
               "b": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0.5, "position": [0.02, 0, 0.25]},
               "c": {"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 1.0, "position": [1.0, 0, 0.05]}},
    "robots": {"robot": {"urdf": "robots/diffbot.urdf", "position": [0, 1.0, 0.06]}},
}
TOUCHING = {("a", "plane"), ("a", "b"), ("c", "plane"), ("robot", "plane")}  # how the scene was built
LINKS = {"robot": ["base_link", "left_wheel_link", "right_wheel_link", "caster_link", "lidar_link"],
         "plane": ["planeLink"], "a": [], "b": [], "c": []}
NAMES = ["plane", "a", "b", "c", "robot"]


@pytest.fixture(scope="module")
def scene() -> Iterator[Any]:
    with make_sim(SCENE) as sim:
        sim.step(240)  # settled: resting contacts with steady forces
        yield sim


def sensor(sim: Any, **config: Any) -> ContactSensor:
    s = ContactSensor("touch", ContactConfig(**config))
    w = sim.world
    s.setup(SetupContext(w, np.random.default_rng(0), "sensors.touch", sim.readings, sim.components, ".",
                         lambda *a, **k: None))
    return s


def touching(a: str, b: str) -> bool:
    return (a, b) in TOUCHING or (b, a) in TOUCHING


def test_the_scene_touches_where_it_was_built_to(scene: Any) -> None:
    w = scene.world
    for name in NAMES:
        others = {w.body_name(c.other) for c in w.contacts(w.body(name))}
        assert others == {o for o in NAMES if touching(name, o)}, name


@st.composite
def configs(draw: Any) -> dict[str, Any]:
    body = draw(st.sampled_from(NAMES))
    cfg: dict[str, Any] = {"body": body, "min_force": draw(st.sampled_from([0.0, 0.5, 3.0, 12.0]))}
    if LINKS[body] and draw(st.booleans()):
        cfg["link"] = draw(st.sampled_from(LINKS[body]))
    if draw(st.booleans()):
        other = draw(st.sampled_from([n for n in NAMES if n != body]))
        cfg["other"] = other
        if LINKS[other] and draw(st.booleans()):
            cfg["other_link"] = draw(st.sampled_from(LINKS[other]))
    elif draw(st.booleans()):
        cfg["ignore"] = tuple(draw(st.lists(st.sampled_from(NAMES), max_size=2, unique=True)))
    return cfg


@settings(max_examples=80, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(configs())
@example({"body": "plane", "other": "robot", "other_link": "left_wheel_link", "min_force": 0.0})  # one of 3 links
def test_readings_are_the_worlds_contacts_filtered_by_the_config(scene: Any, cfg: dict[str, Any]) -> None:
    w = scene.world
    body = w.body(cfg["body"])
    link = w.link(body, cfg["link"]) if "link" in cfg else None
    other = w.body(cfg["other"]) if "other" in cfg else None
    other_link = w.link(other, cfg["other_link"]) if "other_link" in cfg else None
    ignored = {body} | {w.body(n) for n in cfg.get("ignore", ())}
    expected = [c for c in w.contacts(body)
                if (link is None or c.link == link) and (other is None or c.other == other)
                and (other_link is None or c.other_link == other_link)
                and c.other not in ignored and c.normal_force >= cfg["min_force"]]
    got = sensor(scene, **cfg).read()
    assert got.points == len(expected)
    assert got.in_contact == bool(expected)
    assert got.normal_force == pytest.approx(sum(c.normal_force for c in expected), rel=1e-9, abs=1e-12)
    assert got.others == tuple(sorted({w.body_name(c.other) for c in expected}))
    if "link" not in cfg and cfg["min_force"] == 0.0:  # the whole body: the pairs the scene was built with
        names = set(NAMES) - set(cfg.get("ignore", ())) - {cfg["body"]}
        if "other" in cfg and "other_link" not in cfg:
            names &= {cfg["other"]}
        if "other_link" not in cfg:
            assert set(got.others) == {n for n in names if touching(cfg["body"], n)}


@pytest.mark.parametrize(("cfg", "key", "says"), [
    ({"body": "ghost"}, "body", "ghost"),
    ({"body": "robot", "link": "wing"}, "link", "wing"),
    ({"body": "a", "other": "ghost"}, "other", "ghost"),
    ({"body": "a", "other": "robot", "other_link": "wing"}, "other_link", "wing"),
    ({"body": "a", "other_link": "planeLink"}, "other_link", "'other_link' needs 'other'"),
    ({"body": "a", "other": "plane", "ignore": ["b"]}, "ignore", "'ignore' is for contacts with anything"),
    ({"body": "a", "ignore": ["plane", "ghost"]}, "ignore[1]", "ghost"),
])
def test_a_config_mistake_is_an_error_at_its_key(scene: Any, cfg: dict[str, Any], key: str, says: str) -> None:
    """One line at the key that holds the mistake, saying what is wrong (the name, or the rule broken)."""
    with pytest.raises(ConfigError) as err:
        sensor(scene, **cfg)
    assert err.value.key == key
    assert says in err.value.message and "\n" not in err.value.message
