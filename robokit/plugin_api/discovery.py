"""Entry points of installed distributions, read straight from their ``*.dist-info`` / ``*.egg-info`` folders.

``importlib.metadata`` answers the same question, but importing it (with the ``email`` package it parses metadata
with) and building its objects costs about as much as everything else robokit does to start a trivial run. This
reader walks ``sys.path`` the way ``importlib.metadata``'s path finder does — each folder's ``.dist-info`` and
``.egg-info`` entries in listing order, the first distribution of a name winning — and parses ``entry_points.txt``
of the groups asked for, and ``METADATA``'s ``Name``/``Version`` only when a label is needed.

When the environment holds something this reader does not understand (a zip or egg file on ``sys.path``, an
import hook that finds distributions of its own) or a file cannot be read, :func:`entry_points` returns None and
the caller asks ``importlib.metadata`` instead.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from functools import reduce
from importlib import import_module
from typing import Any

_INFO_SUFFIXES = (".dist-info", ".egg-info")


class Distribution:
    """An installed distribution's folder; ``metadata`` holds its ``Name`` and ``Version`` (read on first use)."""

    def __init__(self, path: str) -> None:
        self.path = path
        """The ``.dist-info`` (or ``.egg-info``) folder."""
        self._meta: dict[str, str] | None = None

    @property
    def metadata(self) -> dict[str, str]:
        """``{"Name": ..., "Version": ...}`` from the header of ``METADATA`` (``PKG-INFO`` for an egg-info)."""
        if self._meta is None:
            meta: dict[str, str] = {}
            for file in ("METADATA", "PKG-INFO"):
                try:
                    with open(os.path.join(self.path, file), encoding="utf-8") as fh:
                        for line in fh:
                            if not line.strip():
                                break  # the header ends at the first blank line
                            key, sep, value = line.partition(":")
                            if sep and key in ("Name", "Version") and key not in meta:
                                meta[key] = value.strip()
                    break
                except OSError:
                    continue
            self._meta = meta
        return self._meta


class EntryPoint:
    """``name = value`` in group ``group`` of ``dist``; :meth:`load` imports ``module[:attr]``."""

    __slots__ = ("name", "value", "group", "dist")

    def __init__(self, name: str, value: str, group: str, dist: Distribution) -> None:
        self.name, self.value, self.group, self.dist = name, value, group, dist

    def load(self) -> Any:
        """Import the module and return the object the entry point names."""
        target = self.value.split("[", 1)[0].strip()  # extras ("module:attr [extra]") do not change the target
        module, _, attr = target.partition(":")
        return reduce(getattr, [a for a in attr.strip().split(".") if a], import_module(module.strip()))

    def __repr__(self) -> str:
        return f"EntryPoint(name={self.name!r}, value={self.value!r}, group={self.group!r})"


def _normalized(stem: str) -> str:
    """The distribution name of a ``NAME-VERSION.dist-info`` folder, normalised as ``importlib.metadata`` does
    (each run of ``-``, ``_``, ``.`` made one ``_``, lower case)."""
    name = stem.partition("-")[0].replace("-", "_").replace(".", "_")
    while "__" in name:
        name = name.replace("__", "_")
    return name.lower()


def entry_points(groups: Iterable[str]) -> list[EntryPoint] | None:
    """Every entry point of the given groups, distributions in ``sys.path`` order (None: ask importlib.metadata)."""
    from importlib.machinery import PathFinder

    if any(getattr(f, "find_distributions", None) is not None and f is not PathFinder for f in sys.meta_path):
        return None  # an import hook with distributions of its own
    wanted = set(groups)
    seen: set[str] = set()
    found: list[EntryPoint] = []
    try:
        for entry in sys.path:
            root = entry or "."
            if root.lower().endswith(".egg"):
                return None  # an egg: importlib.metadata reads those
            try:
                listing = os.scandir(root)  # listing order, as os.listdir; entries know whether they are folders
            except NotADirectoryError:
                return None  # a zip: importlib.metadata reads those
            except OSError:  # a missing folder on sys.path is skipped, as importlib.metadata does
                continue
            with listing:
                for item in listing:
                    if not item.name.lower().endswith(_INFO_SUFFIXES):
                        continue
                    key = _normalized(item.name.rsplit(".", 1)[0])
                    if key in seen:
                        continue
                    seen.add(key)
                    if item.is_dir():
                        found.extend(_read(item.path, wanted))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    return found


def _read(path: str, wanted: set[str]) -> list[EntryPoint]:
    """The entry points of the wanted groups in one distribution folder's ``entry_points.txt``."""
    try:
        with open(os.path.join(path, "entry_points.txt"), "rb") as fh:
            text = fh.read().decode("utf-8")
    except FileNotFoundError:
        return []
    if not any(group in text for group in wanted):  # most distributions: nothing of ours to parse
        return []
    dist = Distribution(path)
    group = None
    out = []
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.startswith("[") and line.endswith("]"):
            group = line[1:-1].strip()
        elif group in wanted:
            name, sep, value = line.partition("=")
            if sep:
                out.append(EntryPoint(name.strip(), value.strip(), group, dist))
    return out
