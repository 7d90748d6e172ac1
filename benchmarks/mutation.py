"""A small mutation run: apply one deliberate change at a time to a sample of robokit's code, run the tests that
cover that file, and count how many changes the tests catch ("killed"). Not part of CI (it takes minutes).

    python benchmarks/mutation.py --per-file 5 --seed 1           # the sample reported in the notes
    python benchmarks/mutation.py --files behaviours/sort.py --per-file 20 --list   # just list the mutants

Mutations (on the AST, one site at a time): comparison operators (``<`` <-> ``<=``, ``>`` <-> ``>=``, ``==`` <->
``!=``, ``in`` <-> ``not in``), ``and`` <-> ``or``, ``min`` <-> ``max``, ``+`` <-> ``-``, numbers scaled by 20
(or 0 -> 1), ``True`` <-> ``False``, and a ``not`` dropped. Docstrings are never touched. The file is restored after
each run (also on Ctrl-C). Sites are sampled with a seeded generator, so a sample is repeatable.
"""

from __future__ import annotations

import argparse
import ast
import copy
import random
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

TESTS: dict[str, list[str]] = {
    "behaviours/sort.py": ["tests/test_promises.py::test_sort_stops_at_max_picks", "tests/test_sort_robot.py",
                           "tests/test_promises.py::test_sort_picks_the_nearest_object_to_the_gripper_each_time",
                           "tests/test_outcomes.py"],
    "behaviours/pick_place.py": ["tests/test_arm_pick_place.py", "tests/test_outcomes.py::"
                                 "test_pick_place_goal_is_the_object_resting_at_the_place_pose",
                                 "tests/test_promises.py", "tests/test_preflight.py"],
    "behaviours/patrol_collect.py": ["tests/test_mobile_patrol.py", "tests/test_promises.py"],
    "behaviours/patrol.py": ["tests/test_mobile_patrol.py", "tests/test_mobile_nav.py", "tests/test_promises.py",
                             "tests/test_preflight.py"],
    "behaviours/teleop.py": ["tests/test_teleop.py"],
    "plugins/keyboard.py": ["tests/test_teleop.py"],
    "plugins/ik_arm.py": ["tests/test_arm_ik.py", "tests/test_promises.py", "tests/test_preflight.py"],
    "plugins/gripper.py": ["tests/test_arm_gripper.py", "tests/test_arm_pick_place.py"],
    "robokit/core/simulation.py": ["tests/test_core_scheduler.py", "tests/test_core_world.py", "tests/test_promises.py",
                              "tests/test_outcomes.py", "tests/test_preflight.py"],
    "robokit/core/scheduler.py": ["tests/test_core_scheduler.py", "tests/test_promises.py", "tests/test_outcomes.py"],
    "robokit/core/preflight.py": ["tests/test_preflight.py"],
    "behaviours/avoidance.py": ["tests/test_mobile_nav.py", "tests/test_preflight.py"],
}

SWAP_CMP = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt, ast.Eq: ast.NotEq,
            ast.NotEq: ast.Eq, ast.In: ast.NotIn, ast.NotIn: ast.In, ast.Is: ast.IsNot, ast.IsNot: ast.Is}


@dataclass(frozen=True)
class Mutant:
    """One change: the file, the line, what it does, and the site's index among the file's sites."""

    file: str
    line: int
    what: str
    site: int


def _docstring_ids(tree: ast.AST) -> set[int]:
    ids = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            ids.add(id(body[0].value))
    return ids


def _sites(tree: ast.AST) -> Iterator[tuple[ast.AST, str]]:
    """Every mutable site in a module, in a stable order: (node, description)."""
    skip = _docstring_ids(tree)
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            for i, op in enumerate(node.ops):
                if type(op) in SWAP_CMP:
                    yield node, f"cmp{i}:{type(op).__name__}->{SWAP_CMP[type(op)].__name__}"
        elif isinstance(node, ast.BoolOp):
            yield node, f"boolop:{type(node.op).__name__}->{'Or' if isinstance(node.op, ast.And) else 'And'}"
        elif isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
            yield node, f"binop:{type(node.op).__name__}->{'Sub' if isinstance(node.op, ast.Add) else 'Add'}"
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("min", "max"):
            yield node, f"call:{node.func.id}->{'max' if node.func.id == 'min' else 'min'}"
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            yield node, "not:dropped"
        elif isinstance(node, ast.Constant) and id(node) not in skip:
            if isinstance(node.value, bool):
                yield node, f"const:{node.value}->{not node.value}"
            elif isinstance(node.value, (int, float)):
                yield node, f"const:{node.value!r}->{node.value * 20 if node.value else 1!r}"


def _apply(node: ast.AST, what: str) -> ast.AST:
    """The node with the change ``what`` applied (the replacement node for its parent)."""
    kind, change = what.split(":", 1)
    if kind.startswith("cmp"):
        i = int(kind[3:])
        assert isinstance(node, ast.Compare)
        node.ops[i] = SWAP_CMP[type(node.ops[i])]()
    elif kind == "boolop":
        assert isinstance(node, ast.BoolOp)
        node.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
    elif kind == "binop":
        assert isinstance(node, ast.BinOp)
        node.op = ast.Sub() if isinstance(node.op, ast.Add) else ast.Add()
    elif kind == "call":
        assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
        node.func.id = change.split("->")[1]
    elif kind == "not":
        assert isinstance(node, ast.UnaryOp)
        return node.operand
    elif kind == "const":
        assert isinstance(node, ast.Constant)
        node.value = (not node.value) if isinstance(node.value, bool) else (node.value * 20 if node.value else 1)
    return node


def mutants(file: str) -> list[Mutant]:
    tree = ast.parse((ROOT / file).read_text(encoding="utf-8"))
    return [Mutant(file, getattr(node, "lineno", 0), what, i) for i, (node, what) in enumerate(_sites(tree))]


def mutated_source(m: Mutant) -> str:
    tree = ast.parse((ROOT / m.file).read_text(encoding="utf-8"))
    targets = list(_sites(tree))
    node, what = targets[m.site]
    assert what == m.what
    replacement = _apply(node, what)
    if replacement is not node:
        for parent in ast.walk(tree):
            for field, value in ast.iter_fields(parent):
                if value is node:
                    setattr(parent, field, replacement)
                elif isinstance(value, list):
                    for k, item in enumerate(value):
                        if item is node:
                            value[k] = replacement
    return ast.unparse(ast.fix_missing_locations(copy.deepcopy(tree)))


def run_one(m: Mutant, timeout: float) -> str:
    """Apply, run the file's tests (stop at the first failure), restore. Returns killed / survived / timeout."""
    path = ROOT / m.file
    original = path.read_text(encoding="utf-8")
    try:
        path.write_text(mutated_source(m), encoding="utf-8")
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *TESTS[m.file]]
        try:
            proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return "timeout"  # reported apart: neither caught nor survived
        return "survived" if proc.returncode == 0 else "killed"
    finally:
        path.write_text(original, encoding="utf-8")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="*", default=list(TESTS))
    parser.add_argument("--per-file", type=int, default=5, help="mutants sampled per file")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per mutant's test run")
    parser.add_argument("--list", action="store_true", help="list the sampled mutants, run nothing")
    parser.add_argument("--rerun", metavar="LOG", help="run only the mutants a previous run's output says survived")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    sample: list[Mutant] = []
    for file in args.files:
        found = mutants(file)
        sample.extend(sorted(rng.sample(found, min(args.per_file, len(found))), key=lambda m: m.site))
    if args.rerun:
        lines = Path(args.rerun).read_text(encoding="utf-8").splitlines()
        again = {tuple(line.split()[2:4]) for line in lines if len(line.split()) >= 4 and line.split()[1] == "survived"}
        sample = [m for m in sample if (f"{m.file}:{m.line}", m.what) in again]
    caught = timeouts = 0
    for k, m in enumerate(sample, 1):
        status = "listed" if args.list else run_one(m, args.timeout)
        caught += status == "killed"
        timeouts += status == "timeout"
        print(f"{k:3d}/{len(sample)} {status:8s} {m.file}:{m.line} {m.what}", flush=True)
    if not args.list:
        decided = len(sample) - timeouts
        print(f"caught {caught} of {decided} = {100.0 * caught / max(decided, 1):.0f} % ({timeouts} timed out)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
