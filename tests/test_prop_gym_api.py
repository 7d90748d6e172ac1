"""The gym package's own promises, checked against a plain second computation: the registered ids and what each
makes, the keywords of ``robokit.gym.make``, a linear policy's action and its file (docs/gym.md)."""

from __future__ import annotations

import json
import math
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

gymnasium = pytest.importorskip("gymnasium")

from robokit.gym import ENV_ID, SHIPPED, make, register_envs  # noqa: E402
from robokit.gym.policy import LinearPolicy, load_policy  # noqa: E402
from robokit.gym.spec import finite_or  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FLOATS = st.floats(-50.0, 50.0, allow_nan=False, width=32)


def expected_ids() -> dict[str, dict[str, object] | None]:
    """Every id the docs list, with the keywords its entry point gets: written out, not read from the code."""
    ids: dict[str, dict[str, object] | None] = {ENV_ID: None}
    for name in SHIPPED:
        ids[f"robokit/{name}-v0"] = {"name": name, "reward": None}
        ids[f"robokit/{name}Dense-v0"] = {"name": name, "reward": "dense"}
        ids[f"robokit/{name}Sparse-v0"] = {"name": name, "reward": "sparse"}
    return ids


def test_register_envs_registers_every_id_once_with_its_reward() -> None:
    registry = gymnasium.registry
    saved = {k: v for k, v in registry.items() if k.startswith("robokit/")}
    try:
        for key in saved:
            del registry[key]
        register_envs()
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # registering again must not override (Gymnasium warns when it does)
            register_envs()
        got = {k: v for k, v in registry.items() if k.startswith("robokit/")}
        want = expected_ids()
        assert set(got) == set(want)
        assert got[ENV_ID].entry_point == "robokit.gym.env:RobokitEnv"
        for env_id, kwargs in want.items():
            if kwargs is not None:
                assert got[env_id].entry_point == "robokit.gym:make_shipped", env_id
                assert dict(got[env_id].kwargs) == kwargs, env_id
    finally:
        for key in [k for k in registry if k.startswith("robokit/")]:
            del registry[key]
        registry.update(saved)


def test_make_passes_every_keyword_on() -> None:
    env = make(ROOT / "configs" / "gym" / "reach.toml", render_mode="rgb_array", goal_env=True,
               world__time_step=1 / 200)
    try:
        assert env.render_mode == "rgb_array"
        assert env.env_spec.goal_env and isinstance(env.observation_space, gymnasium.spaces.Dict)
        assert math.isclose(env.cfg.world.time_step, 1 / 200)
        assert env.cfg.world.engine == "pybullet"
    finally:
        env.close()
    flat = make(ROOT / "configs" / "gym" / "reach.toml", goal_env=False, engine="pybullet")
    try:
        assert flat.render_mode is None and not flat.env_spec.goal_env
        assert isinstance(flat.observation_space, gymnasium.spaces.Box)
    finally:
        flat.close()


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 10))
def test_finite_or_keeps_finite_values_only(value: float, default: float) -> None:
    got = finite_or(value, default)
    if math.isfinite(value):
        assert got == value
    else:
        assert got == default


@st.composite
def policies(draw: st.DrawFn) -> tuple[LinearPolicy, np.ndarray]:
    n_obs, n_act = draw(st.integers(1, 6)), draw(st.integers(1, 4))
    arr = lambda *shape: np.array(draw(st.lists(FLOATS, min_size=int(np.prod(shape)),  # noqa: E731
                                                 max_size=int(np.prod(shape)))), dtype=np.float64).reshape(shape)
    std = np.abs(arr(n_obs)) + 0.1
    policy = LinearPolicy(arr(n_act, n_obs) / 10, arr(n_act) / 10, arr(n_obs), std,
                          env={"task": {"type": draw(st.sampled_from(["reach", "push"]))}},
                          meta={"seed": draw(st.integers(0, 99)), "method": "ARS"})
    return policy, arr(n_obs)


@settings(max_examples=60, deadline=None)
@given(policies())
def test_linear_policy_action_against_its_formula_written_plainly(case: tuple[LinearPolicy, np.ndarray]) -> None:
    policy, obs = case
    action = policy.act(obs.tolist())
    assert action.dtype == np.float32 and action.shape == (policy.W.shape[0],)
    for i in range(policy.W.shape[0]):
        total = float(policy.b[i])
        for j in range(policy.W.shape[1]):
            total += float(policy.W[i, j]) * (float(obs[j]) - float(policy.obs_mean[j])) / float(policy.obs_std[j])
        assert action[i] == pytest.approx(min(1.0, max(-1.0, total)), abs=1e-5)


@settings(max_examples=25, deadline=None)
@given(policies())
def test_a_saved_linear_policy_loads_back_whole(tmp_path_factory: pytest.TempPathFactory,
                                                case: tuple[LinearPolicy, np.ndarray]) -> None:
    policy, obs = case
    path = tmp_path_factory.mktemp("policy") / "p.npz"
    policy.save(path)
    loaded = load_policy(path)
    assert isinstance(loaded, LinearPolicy)
    for name in ("W", "b", "obs_mean", "obs_std"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(policy, name))
    assert loaded.env == policy.env and loaded.meta == policy.meta
    np.testing.assert_array_equal(loaded.act(obs), policy.act(obs))


def test_policy_files_that_are_not_policies_are_refused_naming_the_file(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.npz"
    with pytest.raises(ValueError, match=f"policy file '{missing}' not found"):
        load_policy(missing)
    other = tmp_path / "weights.npz"
    np.savez(other, W=np.zeros((1, 1)), b=np.zeros(1), obs_mean=np.zeros(1), obs_std=np.ones(1),
             env=np.array(json.dumps(None)), meta=np.array("{}"))
    with pytest.raises(ValueError, match=f"^{other}: not a robokit linear policy"):
        load_policy(other)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    with pytest.raises(ValueError, match=f"^{garbage}: not a robokit policy"):
        load_policy(garbage)
    single = tmp_path / "single.npy"
    np.save(single, np.zeros(3))
    with pytest.raises(ValueError, match=f"^{single}: not a robokit policy"):
        load_policy(single)
    zipped = tmp_path / "model.zip"  # a .zip is a stable-baselines3 model: read as one, whether or not it is installed
    with zipfile.ZipFile(zipped, "w") as archive:
        archive.writestr("data", "{}")
    with pytest.raises(ValueError, match=f"^{zipped}: .*stable-baselines3"):
        load_policy(zipped)
    unnamed = tmp_path / "partial.npz"
    np.savez(unnamed, kind=np.array("linear"), W=np.zeros((1, 1)))
    with pytest.raises(ValueError, match=f"^{unnamed}: not a robokit policy \\(KeyError"):
        load_policy(unnamed)
