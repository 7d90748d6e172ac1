"""MuJoCo, imported headless: ``MUJOCO_GL=egl`` (Mesa's EGL) unless the environment names another backend. MuJoCo
picks its OpenGL backend when it is first imported, so every module of the mujoco engine imports it from here."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402

__all__ = ["mujoco"]
