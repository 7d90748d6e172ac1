"""The engine seam: plugins and behaviours reach physics only through the World.

Nothing under ``plugins/`` or ``behaviours/`` imports an engine (pybullet, its data and utilities, mujoco, robokit's
engine modules), at module level or inside a function, and none touches the engine handles the PyBullet World
still carries for robokit's own tools (``world.client``, ``world.cid``). The imports are read from the source, so
a lazy import counts. ruff's TID251 rule (pyproject.toml) says the same to an author before a test run does.

The World interface names everything an engine must answer: a World made by ``World(...)`` is the PyBullet engine,
and an engine missing a method cannot be made at all.
"""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest
import tomllib

from robokit.core.world import World
from robokit.engines.interface import World as Interface

ROOT = Path(__file__).resolve().parents[1]
ENGINE_PACKAGES = ("pybullet", "pybullet_data", "pybullet_utils", "mujoco")
ENGINE_MODULES = tuple(f"robokit.engines.{p.stem}" for p in sorted((ROOT / "robokit" / "engines").iterdir())
                       if p.stem not in ("__init__", "interface", "__pycache__") and (p.suffix == ".py" or p.is_dir()))
"""Every engine package (and module) of robokit's engines but the interface: a new engine is banned as soon as it
exists, and a ban covers the package's modules (``robokit.engines.mujoco.world`` is ``robokit.engines.mujoco``'s)."""
ENGINES = ENGINE_PACKAGES + ENGINE_MODULES
ENGINE_HANDLES = ("client", "cid")


def _sources() -> list[Path]:
    return sorted(p for folder in ("plugins", "behaviours") for p in (ROOT / folder).rglob("*.py"))


def _imported(tree: ast.AST) -> list[tuple[int, str]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.append((node.lineno, node.module))
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def _is_engine(module: str) -> bool:
    return any(module == name or module.startswith(name + ".") for name in ENGINES)


def test_the_walk_sees_the_plugins_and_behaviours() -> None:
    names = {p.name for p in _sources()}
    assert {"gripper.py", "ik_arm.py", "lidar.py", "camera.py", "sort.py", "patrol.py"} <= names
    assert set(ENGINE_MODULES) == {"robokit.engines.pybullet", "robokit.engines.mujoco"}


def test_no_plugin_or_behaviour_imports_an_engine() -> None:
    offenders = [f"{path.relative_to(ROOT)}:{line} imports {module}"
                 for path in _sources()
                 for line, module in _imported(ast.parse(path.read_text(encoding="utf-8")))
                 if _is_engine(module)]
    assert offenders == []


def test_no_plugin_or_behaviour_touches_the_engine_handles() -> None:
    offenders = [f"{path.relative_to(ROOT)}:{node.lineno} uses .{node.attr}"
                 for path in _sources()
                 for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
                 if isinstance(node, ast.Attribute) and node.attr in ENGINE_HANDLES]
    assert offenders == []


@pytest.mark.parametrize("source", [
    "import pybullet as p\n",
    "def f():\n    from pybullet_utils import bullet_client\n",
    "import mujoco.viewer\n",
    "from robokit.engines.pybullet import PyBulletWorld\n",
    "from robokit.engines import pybullet\n",
    "import robokit.engines.pybullet.rays as rays\n",
    "from robokit.engines.mujoco.world import MujocoWorld\n",
])
def test_the_check_catches_each_way_of_importing_an_engine(source: str) -> None:
    assert any(_is_engine(module) for _, module in _imported(ast.parse(source)))


def test_the_interface_module_is_allowed() -> None:
    source = "from robokit.engines.interface import KEY_DOWN\nfrom robokit.core.world import World\n"
    assert not any(_is_engine(module) for _, module in _imported(ast.parse(source)))


def test_ruff_bans_the_same_engines_in_plugins_and_behaviours_only() -> None:
    lint = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["ruff"]["lint"]
    assert "TID251" in lint["select"]
    assert set(lint["flake8-tidy-imports"]["banned-api"]) == set(ENGINES)
    assert lint["per-file-ignores"]["!{plugins,behaviours}/**"] == ["TID251"]


def test_world_builds_the_pybullet_engine_by_default() -> None:
    with World(seed=3) as world, World.create("pybullet", seed=3) as same:
        assert isinstance(world, Interface) and world.engine == same.engine == "pybullet"
        assert type(world) is type(same) is World.engine_class("pybullet")


def test_an_unknown_engine_is_one_line_naming_the_known_ones() -> None:
    with pytest.raises(Exception, match=r"unknown engine 'bulet'.*pybullet"):
        World(engine="bulet")


def test_an_engine_missing_a_method_cannot_be_made() -> None:
    abstract = sorted(Interface.__abstractmethods__)
    assert {"joint_states", "set_joint_motors", "contacts", "attach", "ray_caster", "render"} <= set(abstract)

    class Partial(Interface):
        engine = "partial"

    with pytest.raises(TypeError, match="abstract"):
        Partial()


def test_every_interface_method_says_what_it_does() -> None:
    undocumented = [name for name, member in inspect.getmembers(Interface)
                    if not name.startswith("_") and callable(member) and not inspect.getdoc(member)]
    assert undocumented == []
