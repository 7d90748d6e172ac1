"""The house: robokit's modules form no import cycle, and no room imports a room above it.

Imports are read from the source (every ``import`` statement, at module level or inside a function, except those
under ``if TYPE_CHECKING:``, which never run), so a lazy import counts as much as an eager one: a cycle hidden in a
function still ties two modules together.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "robokit"

LAYERS: tuple[tuple[str, ...], ...] = (
    ("robokit", "robokit.errors", "robokit.process"),
    ("robokit.config",),
    ("robokit.plugin_api", "robokit.msgs", "robokit.components"),
    ("robokit.engines",),
    ("robokit.core", "robokit.fsm"),
    ("robokit.report", "robokit.record"),
    ("robokit.runner", "robokit.sweep", "robokit.gym", "robokit.checks", "robokit.server"),
    ("robokit.testing", "robokit.checks.pytest_plugin", "robokit.cli"),
)
"""Rooms from the bottom up: a module may import its own room and the rooms below it, never one above."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST, modules: set[str], package: str) -> set[str]:
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return {name for name in found if name in modules}


def import_graph() -> dict[str, set[str]]:
    """Every robokit module and the robokit modules it imports (itself and its own package left out)."""
    paths = {_module_name(p): p for p in ROOT.rglob("*.py") if "migrations" not in p.parts}
    modules = set(paths)
    graph = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps = _imports(ast.parse(path.read_text(encoding="utf-8")), modules, package)
        graph[name] = {d for d in deps if d != name and not name.startswith(d + ".") and d != "robokit"}
    return graph


def _layer(module: str) -> int:
    best, level = -1, -1
    for index, rooms in enumerate(LAYERS):
        for room in rooms:
            if (module == room or module.startswith(room + ".")) and len(room) > best:
                best, level = len(room), index
    return level


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            strong(v)
    return found


def test_every_module_is_in_a_room() -> None:
    unplaced = sorted(m for m in import_graph() if _layer(m) < 0)
    assert unplaced == []


def test_no_import_cycles() -> None:
    assert _cycles(import_graph()) == []


def test_no_room_imports_a_room_above_it() -> None:
    upward = sorted(f"{m} -> {d}" for m, deps in import_graph().items() for d in deps if _layer(d) > _layer(m))
    assert upward == []


def test_the_checker_sees_a_planted_cycle_and_an_upward_import() -> None:
    graph = {"robokit.config": {"robokit.core.world"}, "robokit.core.world": {"robokit.config"}}
    assert _cycles(graph) == [["robokit.config", "robokit.core.world"]]
    assert _layer("robokit.core.world") > _layer("robokit.config")


def test_every_room_says_what_lives_there_and_what_it_may_import() -> None:
    for room in ("core", "config", "report", "plugin_api", "checks", "process"):
        doc = ast.get_docstring(ast.parse((ROOT / room / "__init__.py").read_text(encoding="utf-8"))) or ""
        assert "May import" in doc, room
