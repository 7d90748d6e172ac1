"""Gymnasium on both engines: the registered ids take the engine as a keyword (``engine=`` or ``world__engine=``);
Gymnasium's ``check_env`` passes, render check included, on ids made through ``gymnasium.make``; ``render_modes``
is what the engine can do on this machine; a window that cannot open is a one-line error, never the end of the
process; a flat env has no ``compute_reward`` and a goal env's step reward is exactly ``compute_reward`` of its
observed goals (float64), which Stable-Baselines3's checker demands.

The default tier checks the reach env on each engine; the slow tier checks every registered id, flat and goal, on
both engines, with Gymnasium's checker and with Stable-Baselines3's (``robokit[rl]``), and the human mode under a
virtual display.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
gymnasium = pytest.importorskip("gymnasium")
pytest.importorskip("mujoco")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import robokit.gym  # noqa: E402,F401 - registers the ids
from robokit.errors import ConfigError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ENGINES = ("pybullet", "mujoco")
IDS = sorted(i for i in gymnasium.registry if i.startswith("robokit/") and i != "robokit/Env-v0")


@pytest.fixture
def headless(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No display, as on a CI runner or a server."""
    monkeypatch.delenv("DISPLAY", raising=False)
    yield


def _checked(env_id: str, **kwargs: object) -> list[str]:
    """Gymnasium's check_env (render check included) on ``gymnasium.make(env_id, **kwargs)``; its warnings but the
    one about checking through gymnasium.make's own wrappers."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gymnasium.make(env_id, **kwargs)
        try:
            check_env(env)
        finally:
            env.close()
    return [str(w.message) for w in caught if "different from the unwrapped" not in str(w.message)]


def test_the_engine_is_a_keyword_of_every_way_to_make_an_env() -> None:
    made = {"mujoco": [gymnasium.make("robokit/Reach-v0", engine="mujoco"),
                       gymnasium.make("robokit/ReachSparse-v0", world__engine="mujoco"),
                       gymnasium.make("robokit/Env-v0", config=str(ROOT / "configs" / "gym" / "reach.toml"),
                                      engine="mujoco"),
                       robokit.gym.make(ROOT / "configs" / "gym" / "reach.toml", engine="mujoco")],
            "pybullet": [gymnasium.make("robokit/Reach-v0", engine="pybullet")]}
    for engine, envs in made.items():
        for env in envs:
            assert env.unwrapped.world.engine == engine
            env.close()


@pytest.mark.parametrize(("engine", "goal_env"), [("pybullet", False), ("mujoco", True)], ids=["flat", "goal"])
def test_check_env_with_its_render_check_passes_on_each_engine(engine: str, goal_env: bool, headless: None) -> None:
    """One flat env and one goal env, one on each engine (the slow tier checks every id both ways on both)."""
    assert _checked("robokit/Reach-v0", engine=engine, goal_env=goal_env) == []


@pytest.mark.parametrize("engine", ENGINES)
def test_render_modes_are_what_the_engine_can_do_here(engine: str, headless: None) -> None:
    env = gymnasium.make("robokit/Reach-v0", engine=engine)
    assert env.metadata["render_modes"] == ["rgb_array"]  # no display here: no window on either engine
    env.close()
    env = gymnasium.make("robokit/Reach-v0", engine=engine, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    camera = env.unwrapped.sim.components["cam"].config
    assert frame.shape == (camera.height, camera.width, 3) and frame.dtype == np.uint8 and frame.std() > 0
    env.close()


@pytest.mark.parametrize("engine", ENGINES)
def test_a_window_that_cannot_open_is_one_line_and_the_process_goes_on(engine: str, headless: None) -> None:
    with pytest.raises(ConfigError) as info:
        gymnasium.make("robokit/Reach-v0", engine=engine, render_mode="human")
    text = str(info.value)
    assert "\n" not in text and "render_mode='human'" in text and engine in text
    assert "DISPLAY is not set" in text


def test_flat_envs_have_no_compute_reward_and_goal_envs_reward_their_observed_goals() -> None:
    flat = gymnasium.make("robokit/PushDense-v0")
    assert not hasattr(flat.unwrapped, "compute_reward")
    flat.close()
    for engine in ENGINES:
        env = gymnasium.make("robokit/PushDense-v0", engine=engine, goal_env=True)
        env.action_space.seed(1)
        obs, _ = env.reset(seed=1)
        for _ in range(3):
            obs, reward, _, _, info = env.step(env.action_space.sample())
            expected = -float(np.linalg.norm(obs["achieved_goal"].astype(np.float64)
                                             - obs["desired_goal"].astype(np.float64)))
            again = env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
            assert type(reward) is float and reward == expected == again and again.dtype == np.float64
        env.close()


# ----------------------------------------------------------------- slow: every id, both checkers, a real window
@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_gymnasiums_check_env_passes_on_every_registered_id_flat_and_goal(engine: str, headless: None) -> None:
    failures = {}
    for env_id in IDS:
        for goal_env in (False, True):
            problems = _checked(env_id, engine=engine, goal_env=goal_env)
            if problems:
                failures[(env_id, goal_env)] = problems
    assert failures == {}


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_stable_baselines3s_check_env_passes_on_every_registered_id_flat_and_goal(engine: str,
                                                                                headless: None) -> None:
    """SB3's checker calls ``compute_reward`` on the env it is handed, which Gymnasium's wrappers do not pass on:
    it gets the env ``gymnasium.make`` made, unwrapped (as SB3's own examples hand it a raw env)."""
    env_checker = pytest.importorskip("stable_baselines3.common.env_checker")  # robokit[rl], slow tier
    for env_id in IDS:
        for goal_env in (False, True):
            env = gymnasium.make(env_id, engine=engine, goal_env=goal_env, render_mode="rgb_array")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("error")  # SB3 warns of what it would not train on
                    env_checker.check_env(env.unwrapped, warn=True, skip_render_check=False)
            finally:
                env.close()


@pytest.mark.slow
def test_with_a_display_pybullet_offers_the_human_mode_and_check_env_opens_it(
        virtual_display: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DISPLAY", virtual_display["DISPLAY"])
    env = gymnasium.make("robokit/Reach-v0", engine="pybullet")
    assert env.metadata["render_modes"] == ["rgb_array", "human"]
    env.close()
    assert _checked("robokit/Reach-v0", engine="pybullet") == []  # builds the human mode too, in the window
