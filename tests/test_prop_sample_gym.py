"""robokit.gym against its own promises: actions outside [-1, 1] act as the nearest bound, an episode is truncated
after exactly ``max_time`` sim seconds, and ``reset(seed=s)`` draws a per-episode randomisation as the first
episode of seed ``s`` did, whatever came before."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.gym.env import RobokitEnv, load_env_config
from robokit.gym.post import PostError, training_url
from robokit.gym.spec import Actions

CONFIGS = Path(__file__).resolve().parents[1] / "configs" / "gym"


@functools.cache
def actions_of(name: str) -> Actions:
    _, spec, _ = load_env_config(CONFIGS / name)
    return Actions(spec, {})


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(["pick.toml", "go_to.toml"]), st.data())
def test_an_action_outside_the_box_acts_as_its_nearest_point(name: str, data: st.DataObject) -> None:
    actions = actions_of(name)
    raw = np.array(data.draw(st.lists(st.floats(-6.0, 6.0), min_size=actions.size, max_size=actions.size)))
    clipped = np.minimum(np.maximum(raw, -1.0), 1.0)  # the oracle: the nearest point of [-1, 1]^n
    assert actions.commands(raw) == actions.commands(clipped)


@pytest.mark.parametrize("max_time", [0.3, 0.5, 1.2])
def test_an_episode_is_truncated_after_exactly_max_time(max_time: float) -> None:
    env = RobokitEnv(CONFIGS / "go_to.toml", overrides={"env.task.max_time": max_time})
    try:
        env.reset(seed=4)
        steps, truncated, terminated = 0, False, False
        while not (truncated or terminated) and steps < 1000:
            _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
            steps += 1
        assert not terminated
        assert truncated
        assert steps == round(max_time * env.env_spec.control_hz)
        assert abs(info["sim_time"] - max_time) < 1e-9
    finally:
        env.close()


def test_reset_with_a_seed_draws_what_that_seed_drew_first() -> None:
    randomize = {"per_episode": True, "mass_scale": [0.5, 1.5], "friction_scale": [0.5, 1.5]}
    env = RobokitEnv(CONFIGS / "go_to.toml", overrides={f"randomize.{k}": v for k, v in randomize.items()})
    try:
        _, first = env.reset(seed=11)
        env.reset(seed=12)
        env.reset()
        _, again = env.reset(seed=11)
        assert again["randomize"] == first["randomize"]
        _, other = env.reset(seed=12)
        assert other["randomize"] != first["randomize"]
    finally:
        env.close()


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["http", "https"]), st.sampled_from(["host", "10.0.0.2:8000", "course.example.org"]),
       st.sampled_from(["", "/", "/api/robotics/result/", "/api/robotics/result", "/api/robotics/training/",
                        "/api/robotics/training"]))
def test_every_documented_server_url_names_the_training_endpoint(scheme: str, host: str, path: str) -> None:
    try:
        url = training_url(f"{scheme}://{host}{path}")
    except PostError as exc:
        raise AssertionError(f"{scheme}://{host}{path} refused: {exc}") from None
    assert url == f"{scheme}://{host}/api/robotics/training/"
