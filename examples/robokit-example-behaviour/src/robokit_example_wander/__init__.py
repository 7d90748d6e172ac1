"""robokit-example-wander: registers the ``wander`` behaviour with robokit (entry point group ``robokit``)."""

from __future__ import annotations

from typing import Any

from robokit import hookimpl

from robokit_example_wander.wander import Wander, WanderConfig

__all__ = ["Wander", "WanderConfig"]


@hookimpl
def robokit_register_behaviours(register: Any) -> None:
    """Make ``type = "wander"`` available in ``[behaviour]``."""
    register("wander", Wander, WanderConfig)
