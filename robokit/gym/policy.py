"""Saved policies: what a training script writes and the ``policy`` behaviour loads. numpy only.

A **linear policy** is an ``.npz`` file: ``action = clip(W @ ((obs - obs_mean) / obs_std) + b, -1, 1)``, plus the
``[env]`` section it was trained with (as JSON under ``env``) so that whoever runs it builds the same observation
and sends the same commands. A **stable-baselines3** ``.zip`` (PPO, SAC, …) is loaded with stable-baselines3 if it
is installed; ``python -m robokit.gym.train`` stores the ``[env]`` section it was trained with in the ``.zip`` (member
``robokit_env.json``, which stable-baselines3 ignores); for a ``.zip`` written elsewhere it comes from an env config.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ENV_MEMBER = "robokit_env.json"
"""The member of a trained ``.zip`` holding ``{"env": [env] section, "meta": training facts}``."""


@dataclass
class LinearPolicy:
    """``action = clip(W @ ((obs - obs_mean) / obs_std) + b, -1, 1)``.

    Attributes:
        W: ``(actions, observations)`` weights. b: ``(actions,)`` bias.
        obs_mean, obs_std: Observation normalisation (running statistics from training).
        env: The ``[env]`` section trained with (a dict), or None.
        meta: Free-form training facts (method, iterations, success rate, seed).
    """

    W: np.ndarray
    b: np.ndarray
    obs_mean: np.ndarray
    obs_std: np.ndarray
    env: dict[str, Any] | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def zeros(cls, n_obs: int, n_act: int) -> LinearPolicy:
        """A policy that always outputs 0, with identity normalisation."""
        return cls(np.zeros((n_act, n_obs)), np.zeros(n_act), np.zeros(n_obs), np.ones(n_obs))

    def act(self, obs: Any) -> np.ndarray:
        """The action for one observation (a flat array), float32 in ``[-1, 1]``."""
        x = (np.asarray(obs, dtype=np.float64) - self.obs_mean) / self.obs_std
        return np.clip(self.W @ x + self.b, -1.0, 1.0).astype(np.float32)  # type: ignore[no-any-return]

    def save(self, path: str | Path) -> None:
        """Write the ``.npz`` (weights, normalisation, the env section and metadata as JSON)."""
        np.savez(path, W=self.W, b=self.b, obs_mean=self.obs_mean, obs_std=self.obs_std,
                 env=np.array(json.dumps(self.env)), meta=np.array(json.dumps(self.meta)), kind=np.array("linear"))

    @classmethod
    def load(cls, path: str | Path) -> LinearPolicy:
        """Read an ``.npz`` written by :meth:`save`."""
        try:
            archive = np.load(path, allow_pickle=False)
        except ValueError:  # numpy's own words for a file that is no array file ("contains pickled data") name no file
            raise ValueError(f"{path}: not a robokit policy (not an .npz file)") from None
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise ValueError(f"{path}: not a robokit policy (a single array, not an .npz file)")
        with archive as data:
            if str(data.get("kind", "")) != "linear":
                raise ValueError(f"{path}: not a robokit linear policy (no kind = 'linear')")
            return cls(data["W"], data["b"], data["obs_mean"], data["obs_std"], json.loads(str(data["env"])),
                       json.loads(str(data["meta"])))


class Sb3Policy:
    """A stable-baselines3 model (``.zip``), acting deterministically. Needs ``pip install stable-baselines3``."""

    def __init__(self, path: str | Path) -> None:
        try:
            import stable_baselines3 as sb3
        except ImportError:
            raise ValueError(f"{path}: a stable-baselines3 model needs `pip install -e '.[rl]'`") from None
        self.env, meta = load_env_member(path)
        named = str(meta.get("method", "")).split()  # "stable-baselines3 SAC + HER" from robokit.gym.train
        names = [n for n in ("PPO", "SAC", "TD3", "A2C", "DDPG") if n in named] or ["PPO", "SAC", "TD3", "A2C", "DDPG"]
        # acting needs no replay buffer: a HER buffer could not be made without an environment
        no_buffer: dict[str, Any] = {"replay_buffer_class": None, "replay_buffer_kwargs": {}}
        model, last = None, ""
        for name in names:
            try:
                model = getattr(sb3, name).load(str(path), device="cpu", custom_objects=no_buffer)
                break
            except Exception as exc:  # noqa: BLE001 - try the next algorithm class
                last = f"{type(exc).__name__}: {exc}".splitlines()[0]
        if model is None:
            raise ValueError(f"{path}: not a stable-baselines3 model this version can load ({last})")
        self.model = model
        self.meta: dict[str, Any] = {"kind": "sb3", "algorithm": type(model).__name__, **meta}

    def act(self, obs: Any) -> np.ndarray:
        """The model's deterministic action."""
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)


def load_env_member(path: str | Path) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """The ``[env]`` section and training facts a ``.zip`` carries (``None, {}`` for one written elsewhere)."""
    with zipfile.ZipFile(path) as archive:
        if ENV_MEMBER not in archive.namelist():
            return None, {}
        data = json.loads(archive.read(ENV_MEMBER))
    return data.get("env"), dict(data.get("meta", {}))


def load_policy(path: str | Path) -> LinearPolicy | Sb3Policy:
    """A linear ``.npz`` policy or a stable-baselines3 ``.zip``.

    Raises:
        ValueError: Missing file or not a policy (one line naming the file).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"policy file {str(path)!r} not found")
    if path.suffix == ".zip":
        return Sb3Policy(path)
    try:
        return LinearPolicy.load(path)
    except (OSError, KeyError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a robokit policy ({type(exc).__name__}: {exc})") from None
