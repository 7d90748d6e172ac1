"""The house: robokit's modules form no import circle, inside a room or across rooms, and no room imports a room
above it.

Imports are read from the source: every ``import`` statement, at module level, inside a function (a lazy import)
or under ``if TYPE_CHECKING:``. A circle counts whatever kind of import closes it: a lazy or type-only import still
ties two modules together, and a reader must hold both in mind at once. A type named only in annotations may come
from a room above (it never runs); a module must not import one above it at run time.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "robokit"

LAYERS: tuple[tuple[str, ...], ...] = (
    ("robokit", "robokit.errors", "robokit.extras", "robokit.process"),
    ("robokit.config",),
    ("robokit.plugin_api", "robokit.msgs", "robokit.components"),
    ("robokit.engines", "robokit.robot", "robokit.planning"),
    ("robokit.core", "robokit.fsm"),
    ("robokit.report", "robokit.record"),
    ("robokit.runner", "robokit.sweep", "robokit.gym", "robokit.checks", "robokit.server", "robokit.live"),
    ("robokit.testing", "robokit.checks.pytest_plugin", "robokit.cli", "robokit.entry"),
)
"""Rooms from the bottom up: a module may import its own room and the rooms below it, never one above."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST, modules: set[str], package: str, *, type_only: bool = True) -> set[str]:
    """The robokit modules ``tree`` imports: every ``import`` statement, wherever it is (module level, in a function,
    and, unless ``type_only`` is False, under ``if TYPE_CHECKING:``). ``from PACKAGE import NAME`` is an import of
    the submodule ``PACKAGE.NAME`` when NAME is one (the package is then only the parent Python loads first), else
    of ``PACKAGE``."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node) and not type_only:
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
            named = {f"{base}.{alias.name}" for alias in node.names}
            found.update(named & modules)
            if named - modules:
                found.add(base)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found & modules


def import_graph(*, type_only: bool = True) -> dict[str, set[str]]:
    """Every robokit module and the robokit modules it imports (itself left out); ``type_only=False`` leaves out
    the imports made only for type checking."""
    paths = {_module_name(p): p for p in ROOT.rglob("*.py") if "migrations" not in p.parts}
    modules = set(paths)
    graph = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        deps = _imports(ast.parse(path.read_text(encoding="utf-8")), modules, package, type_only=type_only)
        graph[name] = deps - {name}
    return graph


def _layer(module: str) -> int:
    best, level = -1, -1
    for index, rooms in enumerate(LAYERS):
        for room in rooms:
            inside = module.startswith(room + ".") and room != "robokit"  # the top package holds only its door
            if (module == room or inside) and len(room) > best:
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
    """No circle anywhere: inside a room (the engines' modules among themselves) or across rooms, lazy and
    type-only imports included."""
    assert _cycles(import_graph()) == []


def test_no_room_imports_a_room_above_it() -> None:
    upward = sorted(f"{m} -> {d}" for m, deps in import_graph(type_only=False).items() for d in deps
                    if _layer(d) > _layer(m))
    assert upward == []


def test_the_checker_sees_a_planted_cycle_and_an_upward_import() -> None:
    graph = {"robokit.config": {"robokit.core.world"}, "robokit.core.world": {"robokit.config"}}
    assert _cycles(graph) == [["robokit.config", "robokit.core.world"]]
    assert _layer("robokit.core.world") > _layer("robokit.config")


PLANTED = {
    "robokit.engines.alpha": "from __future__ import annotations\nfrom robokit.engines import beta\n",
    "robokit.engines.beta": ("from __future__ import annotations\nfrom typing import TYPE_CHECKING\n"
                             "if TYPE_CHECKING:\n    from robokit.engines.gamma import Gamma\n"),
    "robokit.engines.gamma": "def later():\n    from robokit.engines.alpha import thing\n    return thing\n",
    "robokit.engines": "from robokit.engines.alpha import thing\n",
}
"""A circle of three modules inside one room, closed by a type-only import and a lazy one."""


def test_the_checker_sees_a_circle_inside_a_room_closed_by_lazy_and_type_only_imports() -> None:
    modules = set(PLANTED)
    graph = {name: _imports(ast.parse(text), modules, name.rpartition(".")[0]) - {name}
             for name, text in PLANTED.items()}
    assert graph["robokit.engines.alpha"] == {"robokit.engines.beta"}  # the submodule, not its package
    assert _cycles(graph) == [["robokit.engines.alpha", "robokit.engines.beta", "robokit.engines.gamma"]]
    runtime = {name: _imports(ast.parse(text), modules, name.rpartition(".")[0], type_only=False) - {name}
               for name, text in PLANTED.items()}
    assert runtime["robokit.engines.beta"] == set() and _cycles(runtime) == []


def test_every_room_says_what_lives_there_and_what_it_may_import() -> None:
    for room in ("core", "config", "report", "plugin_api", "checks", "process"):
        doc = ast.get_docstring(ast.parse((ROOT / room / "__init__.py").read_text(encoding="utf-8"))) or ""
        assert "May import" in doc, room
