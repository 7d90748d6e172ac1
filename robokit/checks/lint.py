"""A static check for plugin code: no wall clock, no ``time.sleep``, no global or unseeded random generators.

A robokit run is a pure function of its config and seed, stepped in sim time. Code that reads the wall clock,
sleeps, or draws from a process-wide random generator breaks that: runs stop repeating, tests flake, a faster
machine gives another result. This check reads the source (Python's ``ast``; nothing is imported or run) and reports
every such call with its file, line and a code:

========  ==============================================================================================
RK101     wall clock read: ``time.time``/``monotonic``/``perf_counter``/``process_time`` (and ``_ns``),
          ``datetime.now``/``utcnow``/``today``, ``date.today``. Use the sim time ``t`` (or ``world.time``).
RK102     ``time.sleep``: a behaviour waits by staying in a state until enough *sim* time passed.
RK103     a global random generator: the ``random`` module's functions, ``numpy.random.<legacy function>``
          (``rand``, ``normal``, ``seed``, ...). Use ``ctx.rng`` (or ``ctx.tick_rng()`` for sensor noise).
RK104     an unseeded generator: ``numpy.random.default_rng()``, ``random.Random()``, ``SeedSequence()``
          with no seed, which differs on every run.
========  ==============================================================================================

Run it as ``robokit lint PATH ...`` (files or folders; one line per finding and exit code 1 if anything is found,
else one line saying how many files were checked for what) or from a test::

    from robokit.testing import lint_paths

    def test_plugin_code_is_deterministic():
        assert lint_paths(["src/my_plugin"]) == []

A line that really needs one of these (GUI pacing) ends with ``# noqa: RK102`` (or a bare ``# noqa``).
Aliases are followed (``import time as t``, ``from time import sleep``, ``import numpy as np``,
``from numpy import random as npr``); calls through variables the check cannot see are not.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

WALL_CLOCK = {f"time.{n}" for n in ("time", "monotonic", "perf_counter", "process_time", "thread_time",
                                     "time_ns", "monotonic_ns", "perf_counter_ns", "process_time_ns",
                                     "thread_time_ns", "clock_gettime", "clock_gettime_ns")} | {
    "datetime.datetime.now", "datetime.datetime.utcnow", "datetime.datetime.today", "datetime.date.today"}
SLEEP = {"time.sleep", "asyncio.sleep"}
RANDOM_FUNCTIONS = {"random", "uniform", "randint", "randrange", "choice", "choices", "shuffle", "sample", "gauss",
                    "normalvariate", "lognormvariate", "expovariate", "vonmisesvariate", "gammavariate",
                    "betavariate", "paretovariate", "weibullvariate", "triangular", "seed", "getrandbits",
                    "randbytes", "binomialvariate"}
NUMPY_RANDOM_OK = {"default_rng", "Generator", "SeedSequence", "BitGenerator", "PCG64", "PCG64DXSM", "Philox",
                   "SFC64", "MT19937", "RandomState"}
UNSEEDED = {"numpy.random.default_rng", "numpy.random.SeedSequence", "random.Random", "numpy.random.RandomState"}

MESSAGES = {
    "RK101": "reads the wall clock ({name}); use sim time (the step's t, world.time)",
    "RK102": "{name} blocks on the wall clock; wait by staying in a state for sim seconds",
    "RK103": "draws from a global random generator ({name}); use ctx.rng or ctx.tick_rng()",
    "RK104": "{name}() with no seed differs on every run; seed it from ctx.rng (or use ctx.rng)",
}
_NOQA = re.compile(r"#\s*noqa(?::\s*(?P<codes>[A-Z]+[0-9]+(?:\s*,\s*[A-Z]+[0-9]+)*))?", re.IGNORECASE)


@dataclass(frozen=True, order=True)
class Finding:
    """One problem: where (file, line, column), a code (``RK1xx``) and what to do instead."""

    path: str
    line: int
    col: int
    code: str
    message: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.col}: {self.code} {self.message}"


class _Visitor(ast.NodeVisitor):
    """Follows import aliases and reports calls by their fully qualified name."""

    def __init__(self, path: str, lines: list[str]) -> None:
        self.path, self.lines = path, lines
        self.aliases: dict[str, str] = {}
        self.findings: list[Finding] = []

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            if alias.asname:
                self.aliases[alias.asname] = alias.name
            else:
                top = alias.name.split(".")[0]
                self.aliases[top] = top

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.module and not node.level:
            for alias in node.names:
                self.aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"

    def qualified(self, node: ast.expr) -> str | None:
        if isinstance(node, ast.Name):
            return self.aliases.get(node.id)
        if isinstance(node, ast.Attribute):
            base = self.qualified(node.value)
            return f"{base}.{node.attr}" if base else None
        return None

    def visit_Call(self, node: ast.Call) -> None:
        name = self.qualified(node.func)
        if name is not None:
            code = classify(name, has_args=bool(node.args or node.keywords))
            if code is not None:
                self.report(node, code, name)
        self.generic_visit(node)

    def report(self, node: ast.expr, code: str, name: str) -> None:
        line = self.lines[node.lineno - 1] if node.lineno - 1 < len(self.lines) else ""
        noqa = _NOQA.search(line)
        if noqa and (noqa.group("codes") is None or code in re.split(r"\s*,\s*", noqa.group("codes").upper())):
            return
        self.findings.append(Finding(self.path, node.lineno, node.col_offset + 1, code,
                                     MESSAGES[code].format(name=name)))


def classify(name: str, *, has_args: bool) -> str | None:
    """The finding code of a call to the fully qualified ``name``, or None if it is fine."""
    if name in WALL_CLOCK:
        return "RK101"
    if name in SLEEP:
        return "RK102"
    if name in UNSEEDED and not has_args:
        return "RK104"
    parts = name.split(".")
    if len(parts) == 2 and parts[0] == "random" and parts[1] in RANDOM_FUNCTIONS:
        return "RK103"
    if len(parts) == 3 and parts[:2] == ["numpy", "random"] and parts[2] not in NUMPY_RANDOM_OK:
        return "RK103"
    return None


def lint_source(source: str, path: str = "<string>") -> list[Finding]:
    """Findings in one module's source text.

    Raises:
        SyntaxError: The source does not parse.
    """
    tree = ast.parse(source, filename=path)
    visitor = _Visitor(path, source.splitlines())
    visitor.visit(tree)
    return sorted(visitor.findings)


def python_files(paths: Iterable[str | Path]) -> Iterator[Path]:
    """Every ``.py`` file under the given files and folders (folders recursively; hidden folders skipped).

    Raises:
        FileNotFoundError: A path does not exist.
    """
    for raw in paths:
        path = Path(raw)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file or folder")
        if path.is_file():
            yield path
            continue
        for found in sorted(path.rglob("*.py")):
            if not any(part.startswith(".") for part in found.relative_to(path).parts):
                yield found


def lint_paths(paths: Iterable[str | Path]) -> list[Finding]:
    """Findings in every ``.py`` file under ``paths`` (see the module docstring for the codes)."""
    findings: list[Finding] = []
    for file in python_files(paths):
        findings.extend(lint_source(file.read_text(encoding="utf-8"), str(file)))
    return findings


CHECKED = ("wall-clock reads (RK101), sleeps (RK102), global random generators (RK103) "
           "or unseeded generators (RK104)")
"""What a clean lint says it looked for."""


def lint_report(paths: Iterable[str | Path]) -> tuple[list[str], bool]:
    """What ``robokit lint`` prints, and whether it found anything: a line per finding, or (clean) one line naming
    how many Python files were checked, and for what.

    Raises:
        FileNotFoundError: A path does not exist, or holds no Python file.
        SyntaxError: A file does not parse.
    """
    paths = [Path(p) for p in paths]
    files = list(python_files(paths))
    if not files:
        raise FileNotFoundError(f"{', '.join(map(str, paths))}: no Python (.py) file to check")
    findings = [f for file in files for f in lint_source(file.read_text(encoding="utf-8"), str(file))]
    if findings:
        return [str(f) for f in findings], True
    where = ", ".join(map(str, paths))
    return [f"{len(files)} Python file(s) checked ({where}): no {CHECKED}"], False
