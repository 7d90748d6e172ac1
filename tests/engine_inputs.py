"""Inputs the engine property files generate: the engines, and turns to pose bodies at."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

ENGINES = ["pybullet", "mujoco"]

axes = st.tuples(*(st.floats(-1.0, 1.0),) * 3).filter(lambda a: np.linalg.norm(a) > 0.3)
turns = st.floats(0.3, 2.8)  # rad: never the identity, never a half turn (its own inverse)
