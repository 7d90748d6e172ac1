"""The engine property files' ``world`` fixture (a pytest plugin: ``pytest_plugins = ["engine_props"]``)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from engine_inputs import ENGINES

from robokit.engines.interface import World


@pytest.fixture(params=ENGINES)
def world(request: pytest.FixtureRequest) -> Iterator[World]:
    """A fresh world of each engine (skipped where the engine is not installed)."""
    try:
        cls = World.engine_class(request.param)
    except ImportError as exc:
        pytest.skip(f"engine {request.param!r} not installed: {exc}")
    with cls(seed=0) as w:
        yield w
