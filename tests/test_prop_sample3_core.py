"""Two small promises of the core, over generated values.

* ``jitter_colour`` (randomize's colour jitter, docs/randomize.md) moves a colour in HSV: the hue by ``dh`` turns,
  *wrapping* (a red at hue 0.98 jittered by +0.05 is at 0.03, not clamped at 1.0), saturation and value by ``ds``/``dv``
  clamped to 0..1, alpha kept. The oracle reads the result back with ``colorsys`` and compares with ``(h + dh) mod 1``.
* A run's result is JSON: ``RunResult.to_dict()`` turns NaN and +-infinity into None (``jsonable``), so it survives a
  strict ``json.dumps(..., allow_nan=False)`` (what the course server and every other JSON reader need), whatever the
  nesting of lists, tuples and dicts the behaviour's result uses; every finite number is kept as it was.
"""

from __future__ import annotations

import colorsys
import json
import math
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from robokit.core.randomize import jitter_colour
from robokit.core.result import RunResult

FAST = settings(max_examples=60, deadline=None, derandomize=True, database=None)

unit = st.floats(0.0, 1.0)


def hue_gap(a: float, b: float) -> float:
    """Distance of two hues on the circle (turns)."""
    d = abs(a - b) % 1.0
    return min(d, 1.0 - d)


@FAST
@given(h=st.floats(0.0, 0.999), s=st.floats(0.3, 1.0), v=st.floats(0.3, 1.0), alpha=unit,
       dh=st.floats(-0.49, 0.49), ds=st.floats(-0.2, 0.2), dv=st.floats(-0.2, 0.2))
def test_jitter_moves_the_hue_round_the_circle_and_clamps_the_rest(h: float, s: float, v: float, alpha: float,
                                                                   dh: float, ds: float, dv: float) -> None:
    rgba = [*colorsys.hsv_to_rgb(h, s, v), alpha]
    out = jitter_colour(rgba, dh, ds, dv)
    h2, s2, v2 = colorsys.rgb_to_hsv(*out[:3])
    s_want, v_want = min(1.0, max(0.0, s + ds)), min(1.0, max(0.0, v + dv))
    assert out[3] == alpha
    assert math.isclose(v2, v_want, abs_tol=1e-9)
    assert math.isclose(s2, s_want, abs_tol=1e-9)
    if s_want > 1e-6 and v_want > 1e-6:  # the hue of a grey or of black is not defined
        assert hue_gap(h2, (h + dh) % 1.0) < 1e-6, (h, dh, h2)


def test_a_red_near_the_wrap_is_jittered_both_ways() -> None:
    """The documented example: hue 0.98 + 0.05 turns is hue 0.03 (a red stays red, on the other side of 0)."""
    red = [*colorsys.hsv_to_rgb(0.98, 0.9, 0.8), 1.0]
    up = colorsys.rgb_to_hsv(*jitter_colour(red, 0.05, 0.0, 0.0)[:3])[0]
    down = colorsys.rgb_to_hsv(*jitter_colour([*colorsys.hsv_to_rgb(0.02, 0.9, 0.8), 1.0], -0.05, 0.0, 0.0)[:3])[0]
    assert hue_gap(up, 0.03) < 1e-9 and hue_gap(down, 0.97) < 1e-9


special = st.sampled_from([math.inf, -math.inf, math.nan])
leaf = st.one_of(st.floats(allow_nan=True, allow_infinity=True), special, st.integers(-10**6, 10**6), st.booleans(),
                 st.text(max_size=5), st.none())
tree = st.recursive(leaf, lambda inner: st.one_of(st.lists(inner, max_size=4), st.tuples(inner, inner),
                                                  st.dictionaries(st.text(max_size=4), inner, max_size=4)),
                    max_leaves=12)


def plain(value: Any) -> Any:
    """The value as JSON should carry it: tuples as lists, non-finite floats as None (a second computation)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, float) and (math.isnan(value) or math.isinf(value)):
        return None
    return value


@FAST
@given(result=st.dictionaries(st.text(max_size=6), tree, max_size=5), sim_time=st.one_of(special, st.floats(0, 99)))
def test_a_run_result_is_strict_json_whatever_floats_it_holds(result: dict[str, Any], sim_time: float) -> None:
    r = RunResult(run_id="r", robokit_version="0", config="c.toml", behaviour="b", seed=0, outcome="succeeded",
                  reason="", ticks=1, sim_time=sim_time, wall_time=0.0, started_at="", result=result)
    text = json.dumps(r.to_dict(), allow_nan=False)  # raises on NaN / Infinity
    back = json.loads(text)
    assert back["result"] == plain(result)
    assert back["sim_time"] == plain(sim_time)
