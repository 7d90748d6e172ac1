"""Message types live in robokit itself (robokit.msgs); the old robokit_plugins.*_types paths still work, warning."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

import robokit.msgs as msgs

OLD_PATHS = {
    "robokit_plugins.arm_types": "robokit.msgs.arm",
    "robokit_plugins.vision_types": "robokit.msgs.vision",
    "robokit_plugins.mobile_types": "robokit.msgs.mobile",
    "robokit_plugins.keyboard_types": "robokit.msgs.keyboard",
}


@pytest.mark.parametrize("old,new", sorted(OLD_PATHS.items()))
def test_old_import_path_gives_the_same_types_with_a_deprecation_warning(old: str, new: str) -> None:
    sys.modules.pop(old, None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shim = importlib.import_module(old)
    assert any(issubclass(w.category, DeprecationWarning) and new in str(w.message) for w in caught)
    module = importlib.import_module(new)
    assert module.__all__ and shim.__all__ == module.__all__
    for name in module.__all__:
        assert getattr(shim, name) is getattr(module, name), name
        assert getattr(msgs, name) == getattr(module, name), name


def test_msgs_import_neither_pybullet_nor_opencv() -> None:
    code = ("import sys, robokit.msgs; "
            "print(sorted(m for m in ('pybullet', 'cv2', 'robokit_plugins') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_built_in_plugins_and_behaviours_use_the_new_paths() -> None:
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    offenders = [str(p.relative_to(root)) for folder in ("plugins", "behaviours", "robokit")
                 for p in (root / folder).rglob("*.py")
                 if "_types import" in p.read_text(encoding="utf-8") and not p.name.endswith("_types.py")]
    assert offenders == []


def test_a_message_round_trips_between_old_and_new_names() -> None:
    from robokit.msgs import LaserScan, Twist

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from robokit_plugins.mobile_types import Twist as OldTwist
    assert OldTwist(0.2, 0.1) == Twist(0.2, 0.1)
    scan = LaserScan(angle_min=-1.0, angle_max=1.0, angle_increment=1.0, range_min=0.1, range_max=3.0,
                     ranges=np.array([1.0, np.inf, 2.0]), points=np.zeros((3, 3)), origin=(0.0, 0.0, 0.1), yaw=0.0,
                     stamp=0.5)
    assert np.allclose(scan.angles, [-1.0, 0.0, 1.0])
