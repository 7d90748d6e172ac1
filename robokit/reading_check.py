"""Checking sensor readings: non-finite numbers are flagged, values that cannot be serialised are refused.

A reading may be made of ``None``, bools, ints, floats, strings, enums, numpy scalars and numeric arrays, and
tuples (named or not), lists, dicts and dataclasses of those: what :func:`robokit_behaviours.record.to_jsonable`
and the result writer turn into JSON without guessing. Anything else (a socket, a lock, an open file, a custom
object) cannot go into a trace or a result, and the sensor that returned it is named.

NaN is always flagged (REP 117: NaN is an invalid measurement). ``+inf``/``-inf`` are flagged too unless the
sensor declares ``allow_inf = True`` (a lidar's ``+inf`` means "no return").
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Mapping
from typing import Any

import numpy as np


class Unserialisable(Exception):
    """A reading holds a value that cannot be serialised; ``path`` says where (``"accel[2]"``)."""

    def __init__(self, path: str, value: Any) -> None:
        self.path = path
        self.value_type = type(value).__name__
        super().__init__(f"{path or 'the reading'} is a {self.value_type}")


def nonfinite_path(value: Any, allow_inf: bool = False, path: str = "") -> str | None:
    """Where ``value`` holds a NaN (or an infinity, unless ``allow_inf``), e.g. ``"ranges[3]"``; None if nowhere.

    Raises:
        Unserialisable: ``value`` holds something that cannot be serialised.
    """
    if value is None or isinstance(value, (bool, int, str, enum.Enum)):
        return None
    if isinstance(value, float):
        return None if _ok(value, allow_inf) else path or "(value)"
    if isinstance(value, np.ndarray):
        return _array(value, allow_inf, path)
    if isinstance(value, np.generic):
        return nonfinite_path(value.item(), allow_inf, path)
    if isinstance(value, (tuple, list)):
        names = getattr(value, "_fields", None)
        for i, item in enumerate(value):
            found = nonfinite_path(item, allow_inf, _join(path, names[i]) if names else f"{path}[{i}]")
            if found is not None:
                return found
        return None
    if isinstance(value, Mapping):
        for key, item in value.items():
            found = nonfinite_path(item, allow_inf, _join(path, str(key)))
            if found is not None:
                return found
        return None
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            found = nonfinite_path(getattr(value, f.name), allow_inf, _join(path, f.name))
            if found is not None:
                return found
        return None
    raise Unserialisable(path, value)


def _ok(x: float, allow_inf: bool) -> bool:
    return math.isfinite(x) or (allow_inf and not math.isnan(x))


def _array(a: np.ndarray, allow_inf: bool, path: str) -> str | None:
    kind = a.dtype.kind
    if kind in "biuUS":
        return None
    if kind in "fc":
        bad = np.isnan(a) if allow_inf else ~np.isfinite(a)
        if not bad.any():
            return None
        index = np.unravel_index(int(np.argmax(bad)), a.shape)
        return f"{path}[{', '.join(str(int(i)) for i in index)}]"
    if kind == "O":
        for i, item in enumerate(a.ravel()):
            found = nonfinite_path(item, allow_inf, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    raise Unserialisable(path, a)


def _join(path: str, name: str) -> str:
    return f"{path}.{name}" if path else name
