"""Image observations: a camera's RGB as a CNN-ready ``Box(0, 255, (H, W, 3), uint8)``, depth and segmentation as
their own keys, mixed with vectors in a Dict observation."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")

import robokit.gym  # noqa: E402
from robokit.config import read_toml  # noqa: E402
from robokit.errors import ConfigError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
H, W = 40, 56


def camera_env(observations: object) -> dict:
    raw = read_toml(ROOT / "configs" / "gym" / "reach.toml")
    raw["sensors"]["cam"].update(width=W, height=H, near=0.1, far=4.0)
    raw["env"]["observations"] = observations
    return raw


def test_dict_of_images_and_vectors_passes_check_env() -> None:
    from gymnasium import spaces
    from gymnasium.utils.env_checker import check_env

    env = robokit.gym.make(camera_env({"image": "cam.rgb", "depth": "cam.depth", "segmentation": "cam.segmentation",
                                       "state": ["arm.position", "task.goal"]}))
    space = env.observation_space
    assert space["image"] == spaces.Box(0, 255, (H, W, 3), np.uint8)
    assert space["depth"] == spaces.Box(0.0, 4.0, (H, W, 1), np.float32)  # metres, up to the far plane
    assert space["segmentation"].dtype == np.int32 and space["segmentation"].shape == (H, W, 1)
    assert space["state"].shape == (6,)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    assert [str(w.message) for w in caught] == []
    obs, _ = env.reset(seed=2)
    frame = env.unwrapped.sim.readings["cam"]  # the camera's own reading of the same instant
    assert np.array_equal(obs["image"], frame.rgb) and obs["image"].std() > 5
    # depth is clipped into its space: float rounding puts the background a hair beyond the far plane
    assert np.array_equal(obs["depth"][:, :, 0], np.clip(frame.depth, 0.0, 4.0)) and frame.depth.max() > 3.99
    table = env.unwrapped.world.body("table")
    assert np.any(obs["segmentation"] == table) and np.all(obs["segmentation"] >= -1)
    env.close()


def test_a_flat_camera_observation_is_an_image_box() -> None:
    from gymnasium.utils.env_checker import check_env

    env = robokit.gym.make(camera_env(["cam.rgb"]))
    assert env.observation_space.shape == (H, W, 3) and env.observation_space.dtype == np.uint8
    check_env(env, skip_render_check=True)
    env.close()


def test_an_image_inside_a_vector_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"env.observations: 'cam.rgb' is an image: give it a key of its own"):
        robokit.gym.make(camera_env(["arm.position", "cam.rgb"]))


@pytest.mark.slow  # imports torch (robokit[rl], installed in the slow tier only)
def test_sb3_takes_it_as_an_image_space() -> None:
    """stable-baselines3 (robokit[rl]) sees a CNN input, not a 6,720-number vector."""
    preprocessing = pytest.importorskip("stable_baselines3.common.preprocessing")
    env = robokit.gym.make(camera_env({"image": "cam.rgb", "state": ["arm.position"]}))
    assert preprocessing.is_image_space(env.observation_space["image"])
    assert not preprocessing.is_image_space(env.observation_space["state"])
    env.close()
