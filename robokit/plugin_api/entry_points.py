"""The entry points of installed distributions: asked of ``importlib.metadata``, and remembered between runs.

``importlib.metadata`` is the reader: it walks ``sys.path`` and parses every installed distribution's
``entry_points.txt``. Importing it and asking it costs a trivial ``robokit run`` about 115 M instructions, a fifth of
its start-up, and more the more distributions are installed (``benchmarks/startup.py``), while the answer changes
only when something is installed, removed or reinstalled. So the answer for robokit's groups is kept in a small JSON
file in the user's cache folder, with a key: ``sys.path`` and, in each of its folders, the distributions there with
the modification time and size of each one's ``entry_points.txt`` (installing or removing a distribution changes the
list; reinstalling one rewrites its file). A run whose key matches the file reads it and imports nothing else; any
other run asks ``importlib.metadata`` and rewrites the file.

Not remembered (``importlib.metadata`` is asked every time): when an import hook on ``sys.meta_path`` can find
distributions of its own, which no folder listing sees. A cache file that cannot be read, parsed or written is
ignored. The folder is ``$ROBOKIT_CACHE_DIR``, else ``$XDG_CACHE_HOME/robokit``, else ``~/.cache/robokit``.
"""

from __future__ import annotations

import json
import os
import sys
import zlib
from collections.abc import Iterable
from typing import Any, NamedTuple

_INFO_SUFFIXES = (".dist-info", ".egg-info")
FORMAT = 1
"""Version of the cache file's layout; a file of another version is ignored (and rewritten)."""


class EntryPoint(NamedTuple):
    """One entry point: ``name = value`` in ``group``, from distribution ``distribution`` at ``version``."""

    name: str
    value: str
    group: str
    distribution: str
    version: str

    def load(self) -> Any:
        """Import the module and return the object the entry point names (``module[:attr.attr] [extras]``)."""
        import importlib  # not pkgutil.resolve_name: pkgutil's own imports cost every run more than this loop

        module, _, attr = self.value.split("[", 1)[0].partition(":")
        found = importlib.import_module(module.strip())
        for part in attr.strip().split(".") if attr.strip() else ():
            found = getattr(found, part)
        return found


def cache_dir() -> str:
    """The folder of robokit's cache files."""
    explicit = os.environ.get("ROBOKIT_CACHE_DIR")
    if explicit:
        return explicit
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "robokit")


def entry_points(groups: Iterable[str]) -> list[EntryPoint]:
    """Every entry point of ``groups``, in ``importlib.metadata``'s order (each distribution's first copy on
    ``sys.path`` wins), from the cache when nothing was installed or removed since it was written."""
    wanted = list(groups)
    key = _key(wanted)
    if key is None:
        return _ask_importlib(wanted)
    path = os.path.join(cache_dir(), f"entry-points-{zlib.crc32(json.dumps(key[:2]).encode()):08x}.json")
    try:
        with open(path, encoding="utf-8") as fh:
            kept = json.load(fh)
        if kept["key"] == key:
            return [EntryPoint(*item) for item in kept["entry_points"]]
    except (OSError, ValueError, KeyError, TypeError):
        pass
    found = _ask_importlib(wanted)
    _write(path, {"key": key, "entry_points": [list(ep) for ep in found]})
    return found


def _key(groups: list[str]) -> list[Any] | None:
    """What the answer depends on: each ``sys.path`` entry that holds distributions, with those of them that have an
    ``entry_points.txt`` (the file's modification time and size), and each zip on ``sys.path`` (its own). Entries
    without distributions (a script's folder, the working folder of ``python -m``) are left out, so runs from any
    folder share one answer. None when an import hook can find distributions no folder listing sees: then nothing is
    remembered."""
    from importlib.machinery import PathFinder

    if any(getattr(f, "find_distributions", None) is not None and f is not PathFinder for f in sys.meta_path):
        return None
    folders: list[str] = []
    seen: list[Any] = []
    for entry in sys.path:
        folder = os.path.abspath(entry or ".")  # "" is the working folder
        try:
            names = os.listdir(folder)  # names only: cheaper than scandir's entries in a folder of hundreds
        except NotADirectoryError:  # a zip
            folders.append(folder)
            seen.append(_stamp(folder))
            continue
        except OSError:  # missing, or the marker of an import hook: no distributions there
            continue
        infos = [name for name in names if name.lower().endswith(_INFO_SUFFIXES)]
        if infos:
            folders.append(folder)
            seen.append([[name, _stamp(os.path.join(folder, name, "entry_points.txt"))] for name in infos])
    return [[FORMAT, sys.version, *groups], folders, seen]


def _stamp(path: str) -> list[int] | None:
    """A file's modification time (ns) and size; None if there is no such file."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return [st.st_mtime_ns, st.st_size]


def _ask_importlib(groups: list[str]) -> list[EntryPoint]:
    import importlib.metadata as md

    every = md.entry_points()
    labels: dict[int, tuple[str, str]] = {}  # a distribution's METADATA is parsed once, not once per entry point
    found = []
    for group in groups:
        for ep in every.select(group=group):
            dist = ep.dist
            if id(dist) not in labels:
                meta = dist.metadata if dist is not None else None
                name, version = (meta["Name"], meta["Version"]) if meta else ("", "")
                labels[id(dist)] = (name or "<unknown>", version or "")
            found.append(EntryPoint(ep.name, ep.value, ep.group, *labels[id(dist)]))
    return found


def _write(path: str, data: dict[str, Any]) -> None:
    """Replace the cache file in one step (concurrent runs each write a whole file); failures are ignored."""
    tmp = f"{path}.{os.getpid()}.tmp"
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(data, fh)
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
