"""What a sweep's trials depend on, recorded in ``sweep.json`` so a resumed sweep never mixes two different inputs.

The identity holds the config text's digest, the fixed overrides, the extra plugin modules, the digest of every file
the config refers to (a string value in the config, or in a ``--set`` / grid value, that names a file next to the
config: URDFs, policies, data; and the meshes each URDF names), the sweep file's own digest, and the versions of
robokit, pybullet and every plugin distribution. Files bundled with pybullet (``plane.urdf``) are covered by
pybullet's version.

The sweep file's digest is recorded but not compared: a sweep grows by editing it (more seeds, more grid values),
and what in it changes existing trials (the config, ``[set]``, ``plugins``) is compared through the rest.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

URDF_SUFFIXES = (".urdf", ".xacro", ".sdf", ".xml")
_LABELS = {"config_sha256": "the config file's text", "fixed": "the fixed overrides (--set)",
           "plugins": "the --plugin modules"}


def sha256_file(path: Path) -> str:
    """The SHA-256 of a file's bytes, read in blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _strings(value: Any) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, Mapping):
        for v in value.values():
            yield from _strings(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _strings(v)


def _meshes(urdf: Path) -> list[Path]:
    """The mesh files a URDF names (``<mesh filename=...>``), relative to its folder; ``package://`` ones skipped."""
    from xml.etree import ElementTree as ET

    try:
        root = ET.parse(urdf).getroot()
    except (ET.ParseError, OSError):
        return []
    found = []
    for mesh in root.iter("mesh"):
        name = mesh.get("filename") or ""
        if name and "://" not in name:
            candidate = (urdf.parent / name)
            if candidate.is_file():
                found.append(candidate)
    return found


def referenced_files(raw: Mapping[str, Any], base_dir: Path, extra_values: Iterable[Any] = ()) -> list[Path]:
    """Every existing file named by a string in the config tree (or in ``extra_values``), relative to
    ``base_dir``, plus the meshes of each URDF among them; sorted, without duplicates."""
    files: set[Path] = set()
    for text in [*_strings(raw), *_strings(list(extra_values))]:
        if not text or "\n" in text or len(text) > 400:
            continue
        candidate = base_dir / text
        try:
            if not candidate.is_file():
                continue
        except OSError:
            continue
        files.add(candidate.resolve())
        if candidate.suffix.lower() in URDF_SUFFIXES:
            files.update(m.resolve() for m in _meshes(candidate))
    return sorted(files)


def _label(path: Path, base_dir: Path) -> str:
    try:
        return path.relative_to(base_dir.resolve()).as_posix()
    except ValueError:
        return str(path)


def file_digests(raw: Mapping[str, Any], base_dir: Path, extra_values: Iterable[Any] = ()) -> dict[str, str]:
    """``{path relative to the config's folder: sha256}`` of :func:`referenced_files`."""
    return {_label(p, base_dir): sha256_file(p) for p in referenced_files(raw, base_dir, extra_values)}


def versions(plugins: Any) -> dict[str, str]:
    """robokit's, pybullet's and each plugin distribution's version."""
    from importlib import metadata

    from robokit import __version__

    out = {"robokit": __version__}
    try:
        out["pybullet"] = metadata.version("pybullet")
    except metadata.PackageNotFoundError:
        pass
    for ptype in plugins.all_types():
        dist = getattr(ptype, "distribution", None)
        if dist and dist not in out:
            out[str(dist)] = str(getattr(ptype, "version", "") or "")
    return dict(sorted(out.items()))


def what_changed(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """Each difference between a recorded identity and today's, as a short phrase naming what changed.

    Keys the recorded identity does not have (a folder written by an older robokit) are not compared.
    """
    changes = []
    for key in ("config_sha256", "fixed", "plugins"):
        if key in old and old[key] != new.get(key):
            changes.append(f"{_LABELS[key]} changed")
    if "files" in old:
        before, now = old["files"], new.get("files", {})
        for name in sorted(set(before) | set(now)):
            if name not in now:
                changes.append(f"{name} is no longer referred to or is missing")
            elif name not in before:
                changes.append(f"{name} is newly referred to")
            elif before[name] != now[name]:
                changes.append(f"{name} changed (sha256 {before[name][:12]} -> {now[name][:12]})")
    if "versions" in old:
        before, now = old["versions"], new.get("versions", {})
        for name in sorted(set(before) | set(now)):
            if before.get(name) != now.get(name):
                changes.append(f"{name} {before.get(name) or '(absent)'} -> {now.get(name) or '(absent)'}")
    return changes
