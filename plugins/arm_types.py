"""Deprecated: moved to :mod:`robokit.msgs.arm` (import from there, or from :mod:`robokit.msgs`).

This re-export keeps ``robokit_plugins.arm_types`` working for one release (robokit 0.2 removes it). Message types
belong to robokit itself, so a third-party sensor or behaviour imports only ``robokit``.
"""

from __future__ import annotations

import warnings

from robokit.msgs.arm import *  # noqa: F403
from robokit.msgs.arm import __all__  # noqa: F401

warnings.warn(
    "robokit_plugins.arm_types moved to robokit.msgs.arm; the old path goes away in robokit 0.2",
    DeprecationWarning,
    stacklevel=2,
)
