"""The ``colour_detector`` sensor: every cube in view found, located within 1 cm, classes, order, laziness."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from robokit_plugins.colour_detector import fold_yaw

from robokit.core.world import yaw_of
from robokit.msgs.vision import Detections
from robokit.testing import PLANE

EDGE = 0.04


def cube(rgba: list[float], count: int = 1) -> dict[str, Any]:
    return {"shape": "box", "size": [EDGE] * 3, "mass": 0.1, "region": "table", "count": count, "rgba": rgba,
            "yaw_deg_range": [-45, 45]}


def scene(detector: dict[str, Any] | None = None, **cubes: Any) -> dict[str, Any]:
    """Table, two trays, cubes scattered on the table, an overhead camera ``cam`` and a detector ``det``."""
    return {
        "bodies": {
            "plane": PLANE,
            "table": {"urdf": "table/table.urdf", "position": [0.5, 0, -0.625], "fixed_base": True},
            "tray": {"urdf": "tray/traybox.urdf", "position": [0.1, 0.45, 0.0], "scale": 0.5, "fixed_base": True},
            **cubes,
        },
        "regions": {"table": {"low": [0.35, -0.22], "high": [0.7, 0.22], "z": EDGE / 2, "min_spacing": 0.08}},
        "sensors": {
            "cam": {"type": "camera", "eye": [0.5, 0.0, 0.8], "target": [0.5, 0.0, 0.0], "up": [1, 0, 0],
                    "fov": 45, "segmentation": False},
            "det": {"type": "colour_detector", "camera": "cam", "object_height": EDGE, **(detector or {})},
        },
    }


def truth(sim: Any, prefix: str) -> list[tuple[np.ndarray, float]]:
    names = [n for n in sim.world.body_names if n.startswith(prefix)]
    return [(np.asarray(sim.world.pose(n)[0]), yaw_of(sim.world.pose(n)[1])) for n in names]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_cube_is_detected_within_1_cm(sim_factory: Any, seed: int) -> None:
    sim = sim_factory(scene(red=cube([1, 0, 0, 1], 2), blue=cube([0, 0, 1, 1], 2), green=cube([0, 1, 0, 1]),
                            yellow=cube([1, 1, 0, 1])), seed=seed)
    sim.step(30)  # let the cubes settle
    seen = sim.readings["det"]
    assert isinstance(seen, Detections)
    for colour, count in (("red", 2), ("blue", 2), ("green", 1), ("yellow", 1)):
        found = seen.of(colour)
        assert len(found) == count, f"{colour}: {found}"
        for pos, yaw in truth(sim, colour):
            nearest = min(found, key=lambda d: float(np.linalg.norm(np.subtract(d.position, pos))))
            assert np.linalg.norm(np.subtract(nearest.position, pos)) < 0.01
            # a square's yaw is known modulo 90 degrees: compare on that circle (independently of fold_yaw)
            assert abs(math.remainder(nearest.yaw - yaw, math.pi / 2)) < math.radians(5)
            assert nearest.extent[0] == pytest.approx(EDGE, abs=0.006)
    assert len(seen) == 6  # nothing else (table, tray, floor) is mistaken for a colour


def test_detections_are_ordered_and_one_frame_per_look(sim_factory: Any) -> None:
    sim = sim_factory({**scene(red=cube([1, 0, 0, 1], 3)), "world": {"seed": 4}})
    sim.step(5)
    assert sim.readings.computed("cam") == 0
    first = sim.readings["det"]
    again = sim.readings["det"]
    assert again is first and sim.readings.computed("cam") == 1
    keys = [(d.colour, d.pixel[1], d.pixel[0]) for d in first]
    assert keys == sorted(keys) and len(keys) == 3


def test_red_wraps_hue_zero_and_classes_can_be_overridden(sim_factory: Any) -> None:
    # a crimson cube (hue ~345 deg) is red; a purple class added in config; green narrowed to exclude everything
    detector = {"colours": {"purple": {"hue_deg": [270, 310]}, "green": {"hue_deg": [100, 101]}}}
    sim = sim_factory(scene(detector, crimson=cube([1, 0, 0.25, 1]), violet=cube([0.6, 0, 1, 1]),
                            lime=cube([0.2, 1, 0, 1])), seed=5)
    sim.step(10)
    seen = sim.readings["det"]
    assert [d.colour for d in seen] == ["purple", "red"]
    assert seen.colours == ("red", "green", "blue", "yellow", "purple")


def test_min_area_drops_small_blobs(sim_factory: Any) -> None:
    sim = sim_factory(scene({"min_area": 500}, red=cube([1, 0, 0, 1])), seed=1)
    sim.step(5)
    assert len(sim.readings["det"]) == 0


@pytest.mark.parametrize("angle_deg, folded_deg", [(0.0, 0.0), (30.0, 30.0), (50.0, -40.0), (-46.0, 44.0),
                                                   (45.0, -45.0), (-45.0, -45.0), (89.0, -1.0), (135.0, 45.0 - 90.0),
                                                   (-90.0, 0.0), (200.0, 20.0)])
def test_fold_yaw_maps_a_rectangle_angle_into_the_quarter_turn_around_zero(angle_deg: float,
                                                                          folded_deg: float) -> None:
    assert fold_yaw(angle_deg) == pytest.approx(math.radians(folded_deg), abs=1e-12)
