"""What a submitted config is checked with (by :meth:`robokit.server.assignments.Assignment.check_config`): the
keys it changes, the files it names, and robokit's own validation. Every refusal is one line naming the key.

A submission brings a config (and, where allowed, plugin modules), never model files: a model key (``urdf``,
``sdf``, ``mjcf`` of a body or robot) may name only robokit's bundled models or ``pybullet_data``'s, by a relative
name. :func:`scrub` takes the server's own paths out of any text shown to people.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from pathlib import Path, PurePosixPath, PureWindowsPath
from typing import Any


class SubmissionError(Exception):
    """A submitted config that cannot be accepted; ``field`` names the key (``config`` for the file itself)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


def flatten(tree: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """``(dotted key, value)`` for every leaf of a TOML tree; a list of tables is a leaf (compared whole)."""
    if isinstance(tree, dict) and (tree or not prefix):
        for key, value in tree.items():
            yield from flatten(value, f"{prefix}.{key}" if prefix else str(key))
    else:
        yield prefix, tree


def changed_keys(official: dict[str, Any], submitted: dict[str, Any]) -> list[str]:
    """Dotted keys whose value differs, that were added, or that were removed, in the order of the files."""
    a, b = dict(flatten(official)), dict(flatten(submitted))
    return [k for k in [*a, *(k for k in b if k not in a)] if a.get(k, _MISSING) != b.get(k, _MISSING)]


_MISSING = object()


def parse_toml(text: str, field: str = "config") -> dict[str, Any]:
    from robokit.config import tomllib

    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SubmissionError(field, f"TOML syntax error: {exc}") from None


def validate_config(text: str, source: str = "submitted config") -> None:
    """robokit's own config validation (the plugins' schemas included), as ``robokit validate`` does it."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="robokit-validate-") as scratch:
        problem = config_problem(text, source, scratch, {})
    if problem is not None:
        raise SubmissionError(*problem)


def config_problem(text: str, source: str, base_dir: str, overrides: dict[str, Any],
                   modules: tuple[str, ...] = ()) -> tuple[str, str] | None:
    """The first problem robokit's config check finds, as ``(field, one-line message)``; None for a config that
    loads. ``modules``: a student's plugin modules, imported as extra plugins first (only ever in the sandbox's
    process, :func:`robokit.server.sandbox.check_sandboxed`); their failures are field ``plugin``."""
    from robokit.errors import UserError
    from robokit.sweep.trial import build_trial_config, plugins_for

    try:
        plugins = plugins_for(modules)
        build_trial_config(text, source, base_dir, overrides, plugins)
    except UserError as exc:
        key = getattr(exc, "key", None) or "config"
        return str(key), one_line(getattr(exc, "message", None) or str(exc))
    except Exception as exc:
        if not modules:
            raise  # robokit's own plugins failing is a bug, not the student's
        return "plugin", one_line(f"your plugin {', '.join(modules)} failed while loading the config: "
                                  f"{type(exc).__name__}: {exc}")
    return None


def one_line(text: str) -> str:
    return " ".join(text.split())[:500]


PATH_KEYS = ("urdf", "sdf", "mjcf", "policy", "dir", "artifacts_dir", "verify")
"""Keys that name a file or folder, wherever they appear (a body's model, a behaviour's policy file, a reporter's
folder); tests/test_course_paths.py derives the list from every schema and checks it is all here."""


def check_paths(tree: Any, where: str = "") -> None:
    """Refuse a file a submission does not bring: for every path key (:data:`PATH_KEYS`) anywhere in the config, an
    absolute path, ``..``, or a device; and for a model key, a name that is neither robokit's bundled model nor
    ``pybullet_data``'s (a submission brings no model files).

    Raises:
        SubmissionError: naming the key (``bodies.arm.urdf``); the message holds no path of the server.
    """
    from robokit.config import MODEL_FILE_KEYS

    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for key, value in items:
        dotted = f"{where}[{key}]" if isinstance(key, int) else f"{where}.{key}" if where else str(key)
        if isinstance(value, (dict, list)):
            check_paths(value, dotted)
        elif isinstance(value, str) and key in PATH_KEYS:
            problem = path_problem(value) or (model_path_problem(value) if key in MODEL_FILE_KEYS else None)
            if problem is not None:
                raise SubmissionError(dotted, problem)


ONLY = ("a submission may name only robokit's bundled models and pybullet_data's, by a relative name "
        "(e.g. 'franka_panda/panda.urdf'), and files it brings")


def path_problem(value: str) -> str | None:
    """Why ``value`` cannot name a file inside a submission: empty, control characters, absolute, or ``..``."""
    if not value.strip() or any(ord(c) < 32 for c in value):
        return f"{value!r} is not a file name"
    posix, windows = PurePosixPath(value), PureWindowsPath(value)
    if posix.is_absolute() or windows.is_absolute() or windows.drive or value.startswith(("~", "\\")):
        return f"{value!r} is an absolute path: {ONLY}"
    if ".." in posix.parts or ".." in windows.parts:
        return f"{value!r} leaves the submission ('..'): {ONLY}"
    return None


def model_roots() -> list[Path]:
    """Where a submission's model names are looked up: robokit's bundled data, then ``pybullet_data``."""
    import pybullet_data

    from robokit.engines.interface import DATA_DIR

    return [DATA_DIR.resolve(), Path(pybullet_data.getDataPath()).resolve()]


def model_path_problem(value: str) -> str | None:
    """Why a submission may not name ``value`` as a model file (None: it is a packaged model)."""
    problem = path_problem(value)
    if problem is not None:
        return problem
    for root in model_roots():
        candidate = (root / value).resolve()
        if candidate.is_relative_to(root) and candidate.is_file():
            return None
    return f"{value!r} is not one of robokit's bundled models nor pybullet_data's: {ONLY}"


_PATH = re.compile(r"(?<![\w.~:/-])(?:[A-Za-z]:)?(?:[/\\][^\s/\\'\"():,;<>|]+)+[/\\]?")


def _packages() -> list[tuple[str, str]]:
    """robokit's and pybullet_data's folders (as found and resolved) with the name they are shown by, longest
    first."""
    import robokit

    folders = [(Path(robokit.__file__).parent, "robokit")]
    try:
        import pybullet_data

        folders.append((Path(pybullet_data.getDataPath()), "pybullet_data"))
    except ImportError:
        pass
    pairs = {(str(p).rstrip("/\\"), label) for folder, label in folders for p in (folder, folder.resolve())}
    return sorted(pairs, key=lambda x: -len(x[0]))


def scrub(text: str) -> str:
    """``text`` without the server's paths: robokit's and pybullet_data's own files by their packaged name
    (``robokit/data/arm.urdf``), any other absolute path by its last part (``.../secret_key``)."""
    if not text or ("/" not in text and "\\" not in text):
        return text
    packages = _packages()

    def short(match: re.Match[str]) -> str:
        path = match.group(0)
        for root, label in packages:
            if path == root or path.startswith(root + os.sep):
                return label + path[len(root):]
        name = PurePosixPath(path.replace("\\", "/")).name
        return f".../{name}" if name else "..."

    return _PATH.sub(short, re.sub(r"\bfile://(?=/)", "", text))
