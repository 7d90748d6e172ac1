"""pytest fixtures for robokit (loaded automatically through the ``pytest11`` entry point)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest


@pytest.fixture
def sim_factory() -> Iterator[Any]:
    """Build DIRECT-mode simulations with :func:`robokit.testing.make_sim`; all are closed after the test."""
    from robokit.testing import make_sim

    built: list[Any] = []

    def factory(config: Any, **kwargs: Any) -> Any:
        sim = make_sim(config, **kwargs)
        built.append(sim)
        return sim

    yield factory
    for sim in built:
        sim.close()
