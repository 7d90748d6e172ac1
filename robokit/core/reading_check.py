"""Checking sensor readings: non-finite numbers are flagged, values that cannot be serialised are refused.

A reading may be made of ``None``, bools, ints, floats, strings, enums, numpy scalars and numeric arrays, and
tuples (named or not), lists, sets, dicts and dataclasses of those: what :func:`robokit_behaviours.record.to_jsonable`
and the result writer turn into JSON without guessing. Anything else (a socket, a lock, an open file, a custom
object) cannot go into a trace or a result, and the sensor that returned it is named.

NaN is always flagged (REP 117: NaN is an invalid measurement). ``+inf``/``-inf`` are flagged too unless the
sensor declares ``allow_inf = True`` (a lidar's ``+inf`` means "no return").

Cost: a reading is walked in Python (flat tuples of numbers at C speed). :class:`ReadingCheck` walks a sensor's
first reading in full, then every ``k``-th one, ``k`` growing with the reading's size (1 for up to 32 values): a
pose sensor watching 33 bodies is checked every 13th reading (a few per cent of what reading it costs), a lidar
scan every time. The schedule depends only on counts, so runs stay deterministic; a NaN that lasts fewer than
``k`` readings of a large reading can be missed.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

VALUES_PER_CHECK = 32
"""Readings with more values than this are checked every ``1 + values // VALUES_PER_CHECK``-th time."""
ARRAY_COST = 16
"""What checking one numpy array counts for, in values (one C call, but a few microseconds of overhead)."""


class Unserialisable(Exception):
    """A reading holds a value that cannot be serialised; ``path`` says where (``"accel[2]"``)."""

    def __init__(self, path: str, value: Any) -> None:
        self.path = path
        self.value = value
        self.value_type = type(value).__name__
        self.segments: list[str] = []
        super().__init__(f"{path or 'the reading'} is a {self.value_type}")


class ReadingCheck:
    """The check of one sensor's readings: call it with each computed reading.

    Returns the path of a non-finite value in a reading it checked (e.g. ``"ranges[3]"``), else None.

    Raises:
        Unserialisable: The reading holds something that cannot be serialised (checked on the first reading and
            on every reading it walks).
    """

    def __init__(self, allow_inf: bool = False) -> None:
        self.allow_inf = allow_inf
        self.every = 0  # 0 until the first reading has been sized
        self.seen = 0
        self.checked = 0

    def __call__(self, value: Any) -> str | None:
        self.seen += 1
        if self.every == 0:
            counter = [0]
            found = _walk(value, self.allow_inf, counter)
            self.every = 1 + counter[0] // VALUES_PER_CHECK
            self.checked += 1
            return found
        if (self.seen - 1) % self.every:
            return None
        self.checked += 1
        return _walk(value, self.allow_inf, None)


def nonfinite_path(value: Any, allow_inf: bool = False) -> str | None:
    """Where ``value`` holds a NaN (or an infinity, unless ``allow_inf``), e.g. ``"ranges[3]"``; None if nowhere.

    Raises:
        Unserialisable: ``value`` holds something that cannot be serialised.
    """
    return _walk(value, allow_inf, None)


# A walker returns None (all finite) or the path to the bad value as segments, innermost first (built only on the
# way back up from a problem: the common case builds no strings). It counts values into ``counter`` when given.
Path_ = list[str]
Walker = Callable[[Any, bool, "list[int] | None"], "Path_ | None"]
_WALKERS: dict[type, Walker] = {}


def _walk(value: Any, allow_inf: bool, counter: list[int] | None) -> str | None:
    try:
        found = _step(value, allow_inf, counter)
    except Unserialisable as exc:
        raise Unserialisable(_render(exc.segments), exc.value) from None
    return None if found is None else (_render(found) or "(value)")


def _render(segments: list[str]) -> str:
    return "".join(reversed(segments)).lstrip(".")


def _step(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    kind = type(value)
    walker = _WALKERS.get(kind)
    if walker is None:
        walker = _WALKERS[kind] = _walker_for(kind)
    return walker(value, allow_inf, counter)


def _walker_for(kind: type) -> Walker:  # noqa: PLR0911 - one return per kind of value
    if issubclass(kind, (float, np.floating)):
        return _float
    if kind is type(None) or issubclass(kind, (int, str, enum.Enum, np.integer, np.bool_)):
        return _plain
    if issubclass(kind, np.ndarray):
        return _array
    if issubclass(kind, tuple) and hasattr(kind, "_fields"):
        return _named(tuple(kind._fields))  # type: ignore[attr-defined]
    if issubclass(kind, (tuple, list, set, frozenset)):
        return _sequence
    if issubclass(kind, Mapping):
        return _mapping
    if dataclasses.is_dataclass(kind):
        return _named(tuple(f.name for f in dataclasses.fields(kind)), attributes=True)
    return _refuse



def _plain(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    if counter is not None:
        counter[0] += 1
    return None


def _float(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    if counter is not None:
        counter[0] += 1
    if math.isfinite(value) or (allow_inf and not math.isnan(value)):
        return None
    return []


def _refuse(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    exc = Unserialisable("", value)
    exc.segments = []
    exc.value = value
    raise exc


def _all_finite(value: Any, allow_inf: bool) -> bool:
    """A C-speed shortcut for a flat sequence of numbers: NaN and infinities propagate through a sum. False means
    "look closer" (not numbers, or a non-finite sum, which may also be an overflow of large finite values; numpy
    adding a list as an array, or an integer too large for a float, raise instead)."""
    try:
        total = sum(value)
    except (TypeError, ValueError, ArithmeticError):
        return False
    if isinstance(total, (float, int)):
        return math.isfinite(total) or (allow_inf and not math.isnan(total))
    return False


def _sequence(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    if counter is None and _all_finite(value, allow_inf):  # the first, sizing walk always looks at every value
        return None
    for i, item in enumerate(value):
        try:
            found = _step(item, allow_inf, counter)
        except Unserialisable as exc:
            exc.segments.append(f"[{i}]")
            raise
        if found is not None:
            found.append(f"[{i}]")
            return found
    return None


def _mapping(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    for key, item in value.items():
        try:
            found = _step(item, allow_inf, counter)
        except Unserialisable as exc:
            exc.segments.append(f".{key}")
            raise
        if found is not None:
            found.append(f".{key}")
            return found
    return None


def _named(names: tuple[str, ...], attributes: bool = False) -> Walker:
    def walk(value: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
        if counter is None and not attributes and _all_finite(value, allow_inf):
            return None
        items = [getattr(value, n) for n in names] if attributes else value
        for name, item in zip(names, items):  # noqa: B905 - a named tuple has exactly its fields
            try:
                found = _step(item, allow_inf, counter)
            except Unserialisable as exc:
                exc.segments.append(f".{name}")
                raise
            if found is not None:
                found.append(f".{name}")
                return found
        return None

    return walk


def _array(a: Any, allow_inf: bool, counter: list[int] | None) -> Path_ | None:
    kind = a.dtype.kind
    if counter is not None:
        counter[0] += ARRAY_COST  # numpy checks an array in C, but each call costs about this many values
    if kind in "biuUS":
        return None
    if kind in "fc":
        bad = np.isnan(a) if allow_inf else ~np.isfinite(a)
        if not bad.any():
            return None
        index = np.unravel_index(int(np.argmax(bad)), a.shape)
        return [f"[{', '.join(str(int(i)) for i in index)}]"]
    if kind == "O":
        return _sequence(a.ravel(), allow_inf, counter)
    return _refuse(a, allow_inf, counter)
