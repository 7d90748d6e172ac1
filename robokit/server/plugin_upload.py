"""A student's own plugin package, sent with a submission when the assignment allows it (``allow_plugins``).

The package travels as ``{"plugin_files": {"my_sensor.py": "<source>", "pkg/__init__.py": "...", ...}}`` (what
``robokit submit … --plugin PATH`` sends). The server never imports it: it checks the file names, the sizes and
that every file compiles (:func:`check_plugin_files`), then has the config checked with the package in a fresh
sandbox process (:func:`check_plugin_config`), and keeps the files with the submission. The evaluation writes them
into the sandbox's scratch folder (or ships them to the Ray workers) and imports the top-level modules there as
extra plugins (as ``robokit sweep --plugin`` does), so a student's code runs only inside an evaluation process.
"""

from __future__ import annotations

import importlib.util
import re
from collections.abc import Sequence
from typing import Any

from robokit.server.submitted import SubmissionError

MAX_FILES = 64
MAX_BYTES = 256 << 10
PART = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,63}$")


def check_plugin_files(files: Any) -> list[str]:
    """The top-level modules to import from ``files`` (``{relative path: Python source}``).

    Raises:
        SubmissionError: (field ``plugin``) a name that is not a Python module path, too many or too large files, a
            package without ``__init__.py``, a module named like one installed on the server, or a syntax error
            (file and line).
    """
    if not isinstance(files, dict) or not files or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
        raise SubmissionError("plugin", "expected {\"path.py\": \"source\", ...}: the package's Python files")
    if len(files) > MAX_FILES:
        raise SubmissionError("plugin", f"{len(files)} files; at most {MAX_FILES}")
    size = sum(len(v.encode("utf-8")) for v in files.values())
    if size > MAX_BYTES:
        raise SubmissionError("plugin", f"{size} bytes of source; the limit is {MAX_BYTES}")
    tops: dict[str, bool] = {}
    for path, source in files.items():
        parts = path.split("/")
        if not path.endswith(".py") or not all(PART.match(p) for p in [*parts[:-1], parts[-1][:-3]]):
            raise SubmissionError("plugin", f"{path!r}: expected a Python module path like pkg/sensor.py")
        tops[parts[0] if len(parts) > 1 else parts[0][:-3]] = len(parts) > 1
        try:
            compile(source, path, "exec", dont_inherit=True)
        except SyntaxError as exc:
            raise SubmissionError("plugin", f"{path} line {exc.lineno}: {exc.msg}") from None
    for name, package in tops.items():
        if package and f"{name}/__init__.py" not in files:
            raise SubmissionError("plugin", f"{name}/: a package needs {name}/__init__.py")
        if name.startswith("robokit") or importlib.util.find_spec(name) is not None:
            raise SubmissionError("plugin", f"{name!r} is the name of a module installed on the server: rename "
                                  "your package")
    return sorted(tops)


def check_plugin_config(text: str, files: dict[str, str], modules: Sequence[str], overrides: dict[str, Any],
                        source: str = "submitted config") -> None:
    """Load the config with the student's package as a trial will (in the sandbox, never in this process).

    Raises:
        SubmissionError: naming the key the check refuses (``behaviour.speed``), or ``plugin`` when the package
            cannot be imported or the check overran its time limit.
    """
    from robokit.server.sandbox import check_sandboxed

    problem = check_sandboxed(text, source, overrides, files, modules)
    if problem is not None:
        raise SubmissionError(*problem)
