"""robokit: a plugin-based robot behaviour framework on PyBullet.

Importing :mod:`robokit` is cheap: it loads neither pybullet nor OpenCV. Plugins import :data:`hookimpl` from here.
"""

from __future__ import annotations

import pluggy

__version__ = "0.1.0"

hookimpl = pluggy.HookimplMarker("robokit")
"""Marker for hook implementations in robokit plugins (see :mod:`robokit.plugin_api.hookspecs`)."""

__all__ = ["__version__", "hookimpl"]
