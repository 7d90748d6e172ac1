"""xacro files expanded to URDF with the maintained ``xacro`` package (ROS's own, from PyPI; no ROS needed).

The expanded URDF is written to robokit's cache folder under a name made from its content, so the same file and
arguments give the same path and two runs never write over each other. Relative mesh paths are made absolute
(relative to the xacro file's folder) on the way, so the expanded file loads from anywhere.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from robokit.errors import UserError

XACRO_SUFFIX = ".xacro"


def is_xacro(path: str | os.PathLike[str]) -> bool:
    """True for a file name ending in ``.xacro`` (``robot.urdf.xacro``, ``robot.xacro``)."""
    return str(path).lower().endswith(XACRO_SUFFIX)


def expanded_dir() -> Path:
    """Where expanded URDFs are kept: ``<robokit cache>/xacro``."""
    from robokit.plugin_api.entry_points import cache_dir

    return Path(cache_dir()) / "xacro"


def expand_text(path: Path, args: Mapping[str, object] | None = None) -> str:
    """The URDF text a xacro file expands to with ``args`` (``<xacro:arg>`` values; numbers are written as text).

    Raises:
        UserError: One line ``FILE:LINE: what xacro said`` (the line when it can be found).
    """
    try:
        import xacro
    except ImportError:  # pragma: no cover - a dependency of robokit
        raise UserError(f"{path}: reading xacro files needs the 'xacro' package: pip install xacro") from None
    import xml.parsers.expat

    mappings = {str(k): _arg_text(v) for k, v in (args or {}).items()}
    try:
        doc = xacro.process_file(str(path), mappings=mappings)
    except xml.parsers.expat.ExpatError as exc:
        where = _current_file(xacro, path)
        raise UserError(f"{where}:{exc.lineno}: not well-formed XML: {xml.parsers.expat.ErrorString(exc.code)}"
                        ) from None
    except Exception as exc:  # xacro raises XacroException and plain errors (NameError, ...) alike
        where = _current_file(xacro, path)
        message = " ".join(str(exc).split())
        line = _find_line(where, message)
        raise UserError(f"{where}{f':{line}' if line else ''}: xacro: {message}") from None
    text: str = doc.toprettyxml(indent="  ")
    return text


def _arg_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _current_file(xacro: object, path: Path) -> Path:
    """The file xacro was reading when it stopped (an included file, or the one given)."""
    stack = getattr(xacro, "filestack", None) or []
    last = next((f for f in reversed(stack) if f), None)
    return Path(last) if last else path


_QUOTED = re.compile(r"'([^']{1,200})'")


def _find_line(path: Path, message: str) -> int | None:
    """The first line of ``path`` that holds something the message quotes (an expression, a macro or property
    name, an included file), or None. xacro keeps no line numbers of its own."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError:
        return None
    needles = _QUOTED.findall(message)
    for pattern in (r"macro name: xacro:(\S+)", r"substitution argument (\S+)", r"[Pp]roperty (\S+)",
                    r"No such file or directory: (\S+)"):
        needles += re.findall(pattern, message)
    for needle in needles:
        needle = needle.strip().rstrip(".")
        variants = [needle, os.path.basename(needle)] if "/" in needle else [needle]
        for variant in variants:
            for number, line in enumerate(lines, 1):
                if variant and variant in line:
                    return number
    return None


def package_candidates(folder: Path, name: str) -> list[Path]:
    """Where a ``package://PKG/rest`` mesh may be, seen from a robot file in ``folder`` (as PyBullet looks: the
    path with and without the package's name, under the folder and a few of its parents)."""
    rest = name[len("package://"):]
    tails = [rest, rest.partition("/")[2]]
    return [base / tail for base in [folder, *list(folder.parents)[:3]] for tail in tails if tail]


def _absolute_meshes(text: str, folder: Path) -> str:
    """Rewrite relative ``<mesh filename>`` values, and ``package://`` ones found near ``folder``, to absolute paths
    (the expanded file lives in the cache, not beside the xacro file)."""
    root = ET.fromstring(text)
    changed = False
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        if name.startswith("package://"):
            found = next((c for c in package_candidates(folder, name) if c.is_file()), None)
            if found is not None:
                mesh.set("filename", str(found.resolve()))
                changed = True
        elif name and "://" not in name and not os.path.isabs(name):
            mesh.set("filename", str((folder / name).resolve()))
            changed = True
    if not changed:
        return text
    return ET.tostring(root, encoding="unicode", xml_declaration=True)


def expand_xacro(path: str | os.PathLike[str], args: Mapping[str, object] | None = None,
                 *, out_dir: Path | None = None) -> Path:
    """Expand a xacro file to a URDF file and return the URDF's path.

    The file is written atomically (a temporary name in the same folder, then renamed) into ``out_dir`` (default
    :func:`expanded_dir`) under ``<stem>-<hash of the content>.urdf``.

    Raises:
        UserError: The file is missing, or xacro refused it (``FILE:LINE: message``).
    """
    src = Path(path)
    if not src.is_file():
        raise UserError(f"{src}: no such xacro file")
    src = src.resolve()
    text = _absolute_meshes(expand_text(src, args), src.parent)
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    stem = src.name[: -len(XACRO_SUFFIX)]
    stem = stem[:-5] if stem.lower().endswith(".urdf") else stem
    folder = out_dir or expanded_dir()
    target = folder / f"{stem}-{digest}.urdf"
    if target.is_file():
        return target
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{stem}-", suffix=".tmp", dir=folder)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, target)
    except OSError as exc:
        raise UserError(f"{src}: cannot write the expanded URDF in {folder}: {exc.strerror or exc}") from None
    return target
