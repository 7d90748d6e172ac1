"""robokit: a plugin-based robot behaviour framework on PyBullet.

Importing :mod:`robokit` is cheap: it loads neither pybullet nor OpenCV. Plugins import :data:`hookimpl` from here.
"""

from __future__ import annotations

__version__ = "0.1.0"

TYPE_CHECKING = False  # as typing.TYPE_CHECKING (which type checkers read as true) without importing typing

if TYPE_CHECKING:
    import pluggy

    hookimpl: pluggy.HookimplMarker
    """Marker for hook implementations in robokit plugins (see :mod:`robokit.plugin_api.hookspecs`)."""


def __getattr__(name: str) -> object:
    """``hookimpl`` is made on first use: importing :mod:`robokit` stays free of pluggy, so the console script's
    entry (:mod:`robokit.entry`) installs its signal handlers before anything heavy is imported."""
    if name == "hookimpl":
        import pluggy

        marker = globals()["hookimpl"] = pluggy.HookimplMarker("robokit")
        return marker
    raise AttributeError(f"module 'robokit' has no attribute {name!r}")

__all__ = ["__version__", "hookimpl"]
