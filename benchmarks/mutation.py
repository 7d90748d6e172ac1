"""Mutation testing for robokit: plant one realistic bug at a time and check that the tests covering its file fail.

Two sources of mutants:

* **the corpus** (default): hand-written, behaviour-level bugs in ``benchmarks/mutants/corpus.toml`` -- each one a
  file, an original snippet, its replacement, the area and the behaviour it breaks (a wrong sign, a swapped branch,
  an off-by-one, a wrong bound, a dropped clamp, a wrong unit). The corpus also maps each file to the tests that
  cover it.
* ``--ast``: mechanical operator swaps sampled from the AST (``<`` <-> ``<=``, ``+`` <-> ``-``, ``min`` <-> ``max``,
  constants scaled, ``not`` dropped ...), the older sampler, for a quick look at a file the corpus does not cover.

How a mutant runs: the working tree (or ``--rev``'s tree) is copied once per worker into a temporary folder, with
``robokit_plugins`` / ``robokit_behaviours`` links to ``plugins/`` / ``behaviours/`` so that the copy's code is what
gets imported (the editable install maps those two package names to the source checkout; mutmut itself runs the
same way, room by room, in ``benchmarks/mutation_rooms.py`` -- the measure; this corpus is a regression set); the
copy goes first on
``PYTHONPATH`` (subprocesses -- CLI runs, sweep workers -- inherit it). One mutant is written into the copy, the
file's tests run with ``-x -q -p no:randomly -n 0`` and a per-mutant timeout, and the file is restored. Your
checkout is never touched, so you can keep working while it runs.

    python benchmarks/mutation.py                                  # the whole corpus, 1 worker, table per area
    python benchmarks/mutation.py --workers 2 --log /tmp/mut.log   # 2 workers, one line per mutant into a log
    python benchmarks/mutation.py --area gym --list                # list one area's mutants, run nothing
    python benchmarks/mutation.py --changed main                   # only mutants whose file or tests changed
    python benchmarks/mutation.py --ids dd-turn-sign sort-retry-off-by-one
    python benchmarks/mutation.py --rev HEAD~3                     # score an older tree (e.g. before new tests)
    python benchmarks/mutation.py --files plugins/pid.py --tests tests/test_pins_pid.py   # quick: one test file
    python benchmarks/mutation.py --check                          # each snippet still matches its file?
    python benchmarks/mutation.py --corpus sample.toml --map benchmarks/mutants/corpus.toml --then-all
                        # a sample written by someone else, judged like an outside sample: the file's tests, then
                        # the whole default tier for what they miss (add --grouped: what they miss shares the
                        # tier's runs, each failing test traced back to its mutant by halving)
    python benchmarks/mutation.py --ast --files behaviours/sort.py --per-file 20 --seed 1

The table gives two scores per area: **before** counts kills by the older tests only, **after** by every test; the
tests whose path contains ``test_pins_`` (the pins written for this sample) run last, so one run measures both.

Statuses: ``killed`` (a test failed), ``timeout`` (the tests hung past ``--timeout``: caught, but fix the hang),
``survived`` (every test passed), ``stale`` (the original snippet no longer occurs exactly once: re-anchor it),
``no-tests`` (none of the mapped test files exist in the tree).
"""

from __future__ import annotations

import argparse
import ast
import copy
import fnmatch
import os
import queue
import random
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "benchmarks" / "mutants" / "corpus.toml"
AREAS = ("core", "config", "plugins", "behaviours", "record", "sweep", "server", "gym", "report", "engines")
STATUSES = ("killed", "timeout", "survived", "stale", "no-tests")
PYTEST = ["-x", "-q", "-p", "no:randomly", "-p", "no:cacheprovider", "-n", "0"]


# ---------------------------------------------------------------------------------------------------- the corpus
@dataclass(frozen=True)
class Mutant:
    """One planted bug: ``original`` (occurring exactly once in ``file``) replaced by ``replacement``."""

    id: str
    file: str
    area: str
    original: str
    replacement: str
    breaks: str
    tests: tuple[str, ...] = field(default=())


def tests_naming(file: str, limit: int = 8) -> tuple[str, ...]:
    """Test files whose text names ``file``'s module by its import path (``robokit.record.export``,
    ``robokit_plugins.gripper``), the ones naming it most first: the map for a file the corpus does not cover."""
    stem = file[:-3].replace("/", ".").removesuffix(".__init__")
    if stem.startswith(("plugins.", "behaviours.")):
        stem = "robokit_" + stem
    texts = {f"tests/{t.name}": t.read_text(encoding="utf-8") for t in sorted((ROOT / "tests").glob("test_*.py"))}
    while stem.count(".") >= 1:  # the module, else its package (robokit.engines.pybullet), ...
        counts = sorted((-text.count(stem), name) for name, text in texts.items() if stem in text)
        if counts:
            return tuple(name for _, name in counts[:limit])
        stem = stem.rsplit(".", 1)[0]
    return ("tests",)  # named nowhere: the whole default tier


def room_tests(file: str) -> tuple[str, ...]:
    """The tests of the mutmut rooms (``mutation_rooms.py``) that mutate ``file``: rooms naming it first, then rooms
    taking it by a pattern, each smaller room first."""
    from mutation_rooms import ROOMS  # noqa: PLC0415 - a sibling script, loaded only when a map is read

    name = file
    for src, pkg in (("plugins/", "robokit_plugins/"), ("behaviours/", "robokit_behaviours/")):
        if file.startswith(src):
            name = pkg + file[len(src):]
    rooms = [(any("*" in f for f in files), len(tests), tests) for files, tests in ROOMS.values()
             if any(fnmatch.fnmatch(name, f) for f in files)]
    return tuple(dict.fromkeys(t for *_, tests in sorted(rooms) for t in tests))


def load_corpus(path: Path = CORPUS, map_path: Path | None = None) -> list[Mutant]:
    """The corpus' mutants, each with its file's tests (the mutant's own ``tests`` key overrides them). With
    ``map_path``, the file map is read from that toml instead (a sample written without the corpus), each file's
    tests joined by the (up to four) property files that name its module most, and a file it does not map gets the
    test files that name its module (``tests_naming``)."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    files = data.get("files", {})
    if map_path is not None:
        files = {**tomllib.loads(map_path.read_text(encoding="utf-8")).get("files", {}), **files}
    out = []
    for m in data["mutant"]:
        spec = files.get(m["file"], {})
        area = m.get("area") or spec.get("area")
        if area not in AREAS:
            raise SystemExit(f"{path}: mutant {m['id']}: area {area!r} is not one of {', '.join(AREAS)}")
        tests = tuple(m.get("tests") or spec.get("tests") or ())
        if map_path is not None and not m.get("tests"):  # the map's tests, the rooms', the properties naming it
            props = tuple(t for t in tests_naming(m["file"], limit=40) if "/test_prop_" in t)[:4]
            tests = tuple(dict.fromkeys(tests + room_tests(m["file"]) + props))[:8] or tests_naming(m["file"])
        if not tests:
            raise SystemExit(f"{path}: mutant {m['id']}: no tests for {m['file']} ([files.\"{m['file']}\"] tests)")
        out.append(Mutant(m["id"], m["file"], area, m["original"], m["replacement"], m.get("breaks", ""), tests))
    ids = [m.id for m in out]
    dupes = sorted({i for i in ids if ids.count(i) > 1})
    if dupes:
        raise SystemExit(f"{path}: duplicate mutant ids: {', '.join(dupes)}")
    return out


def apply(m: Mutant, text: str) -> str | None:
    """The file's text with the mutant planted, or None when the original snippet is not there exactly once."""
    if text.count(m.original) != 1:
        return None
    return text.replace(m.original, m.replacement)


# ---------------------------------------------------------------------------------------------------- snapshots
def _files(rev: str | None) -> list[str]:
    if rev is None:
        out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT, capture_output=True,
                             text=True, check=True).stdout
    else:
        out = subprocess.run(["git", "ls-tree", "-r", "--name-only", rev], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout
    return [f for f in out.splitlines() if f and not f.startswith(".ci/venv")]


def snapshot(dest: Path, rev: str | None) -> Path:
    """A copy of the working tree (or of ``rev``'s tree) at ``dest``, importable in place of the checkout."""
    dest.mkdir(parents=True)
    for rel in _files(rev):
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if rev is None:
            src = ROOT / rel
            if src.is_file():
                shutil.copy2(src, target)
        else:
            blob = subprocess.run(["git", "show", f"{rev}:{rel}"], cwd=ROOT, capture_output=True, check=True).stdout
            target.write_bytes(blob)
    (dest / "robokit_plugins").symlink_to("plugins", target_is_directory=True)
    (dest / "robokit_behaviours").symlink_to("behaviours", target_is_directory=True)
    return dest


def ordered(tests: tuple[str, ...], new: str) -> list[str]:
    """The tests in corpus order, the ones whose path contains ``new`` last (so a kill by the older tests is seen
    first, and a mutant only the new tests catch counts for the "after" score alone)."""
    return [t for t in tests if new not in t] + [t for t in tests if new in t]


def run_tests(tree: Path, tests: tuple[str, ...], timeout: float, new: str = "test_pins_") -> tuple[str, float, str]:
    """Run the tests that exist in ``tree``; (status, seconds, the failing test or the last line of output)."""
    present = [t for t in ordered(tests, new) if (tree / t.split("::")[0]).exists()]
    if not present:
        return "no-tests", 0.0, ""
    env = {**os.environ, "PYTHONPATH": f"{tree}{os.pathsep}{os.environ.get('PYTHONPATH', '')}".rstrip(os.pathsep),
           "PYTHONDONTWRITEBYTECODE": "1"}
    cmd = [sys.executable, "-m", "pytest", *PYTEST, "-rfE", f"--timeout={int(timeout)}", *present]
    start = time.monotonic()
    try:
        proc = subprocess.run(cmd, cwd=tree, capture_output=True, text=True, timeout=timeout + 60, env=env)
    except subprocess.TimeoutExpired:
        return "timeout", time.monotonic() - start, "no answer within the per-mutant timeout"
    took = time.monotonic() - start
    lines = proc.stdout.strip().splitlines()
    failing = [ln.split(" ", 2)[1] for ln in lines if ln.startswith(("FAILED ", "ERROR ")) and len(ln.split()) > 1]
    tail = failing[0] if failing else (lines or [""])[-1]
    if proc.returncode == 0:
        return "survived", took, tail
    if proc.returncode == 5:
        return "no-tests", took, tail
    if "Timeout" in proc.stdout and "+++++" in proc.stdout:
        return "timeout", took, tail  # pytest-timeout stopped a hanging test
    return "killed", took, tail


def run_mutant(tree: Path, m: Mutant, timeout: float, then_all: bool = False,
               tier: tuple[str, ...] = ("tests",)) -> tuple[str, float, str]:
    """Plant ``m`` in ``tree``, run its tests (and, with ``then_all``, the whole default tier when they pass),
    restore the file."""
    path = tree / m.file
    if not path.exists():
        return "stale", 0.0, f"{m.file} does not exist"
    original = path.read_bytes()
    mutated = apply(m, original.decode("utf-8"))
    if mutated is None:
        return "stale", 0.0, f"original snippet found {original.decode('utf-8').count(m.original)} times"
    try:
        path.write_text(mutated, encoding="utf-8")
        status, took, tail = run_tests(tree, m.tests, timeout)
        if then_all and status in ("survived", "no-tests"):
            status, more, tail = run_tests(tree, tier, timeout * 4)
            took += more
            tail = tail if status == "survived" else f"{tail} (whole tier)"
        return status, took, tail
    finally:
        path.write_bytes(original)


def failing_tests(tree: Path, tests: list[str], timeout: float) -> set[str]:
    """The node ids of ``tests`` that fail or error in ``tree`` (no ``-x``: every failure is seen)."""
    env = {**os.environ, "PYTHONPATH": f"{tree}{os.pathsep}{os.environ.get('PYTHONPATH', '')}".rstrip(os.pathsep),
           "PYTHONDONTWRITEBYTECODE": "1"}
    cmd = [sys.executable, "-m", "pytest", *[a for a in PYTEST if a != "-x"], "-rfE", f"--timeout={int(timeout)}",
           *tests]
    try:
        proc = subprocess.run(cmd, cwd=tree, capture_output=True, text=True, timeout=timeout * 8 + 600, env=env)
    except subprocess.TimeoutExpired:
        return set(tests)  # the run hung as a whole: every test it was given counts as failing
    return {ln.split()[1] for ln in proc.stdout.splitlines()
            if ln.startswith(("FAILED ", "ERROR ")) and len(ln.split()) > 1}


def _fails(node: str, failed: set[str]) -> bool:
    """Whether ``node`` (a test, or a module whose collection may have failed) is among the failures."""
    return any(f == node or f.startswith(node + "::") or node.startswith(f + "::") for f in failed)


def whole_tier_grouped(tree: Path, mutants: list[Mutant], timeout: float, tier: tuple[str, ...] = ("tests",),
                       say: Callable[[str], None] = print) -> dict[str, str]:
    """Judge the mutants their files' tests missed by the whole default tier, sharing its runs: every one planted at
    once, the tier run once without ``-x``, then each failing test traced to the mutant that fails it alone by
    splitting the planted set in halves (only the failing tests re-run). The mutants left untraced are planted
    together again against the tests that failed, since one may have hidden another's failure in the same test.
    Returns mutant id -> a test that fails with it alone; an id not returned escaped the whole tier."""
    originals = {m.file: (tree / m.file).read_bytes() for m in mutants}
    caught: dict[str, str] = {}

    def plant(subset: list[Mutant]) -> list[Mutant]:
        for f, text in originals.items():
            (tree / f).write_bytes(text)
        taken = []
        for m in subset:
            new = apply(m, (tree / m.file).read_text(encoding="utf-8"))
            if new is not None:  # a mutant of a snippet another one changed waits for a later group
                (tree / m.file).write_text(new, encoding="utf-8")
                taken.append(m)
        return taken

    def split(subset: list[Mutant], hit: list[str]) -> None:
        """``hit`` failed with ``subset`` planted: find which of them fails each alone."""
        if len(subset) == 1:
            caught[subset[0].id] = hit[0]
            return
        for half in (subset[: len(subset) // 2], subset[len(subset) // 2:]):
            plant(half)
            failed = failing_tests(tree, hit, timeout)
            again = [t for t in hit if _fails(t, failed)]
            say(f"  {len(half)} planted, {len(hit)} tests re-run: {len(again)} failed")
            if again:
                split(half, again)

    try:
        pending = list(mutants)
        while pending:
            group = plant(pending)
            if not group:
                break
            later = [m for m in pending if m not in group]
            tests = list(tier)
            while group:
                plant(group)
                failed = failing_tests(tree, tests, timeout * 4)
                whole = tests == list(tier)
                hit = sorted(failed) if whole else [t for t in tests if _fails(t, failed)]
                say(f"{'whole tier' if whole else 'failed tests again'}: {len(group)} planted "
                    f"together, {len(hit)} tests failed")
                before = len(caught)
                if hit:
                    split(group, hit)
                group = [m for m in group if m.id not in caught]
                if len(caught) == before:
                    break  # what still fails needs a combination of mutants: none of them is caught alone
                tests = hit
            pending = later
    finally:
        for f, text in originals.items():
            (tree / f).write_bytes(text)
    return caught


# ---------------------------------------------------------------------------------------------------- reporting
def table(rows: list[tuple[Mutant, str, str]], new: str = "test_pins_") -> str:
    """Per-area score: caught = killed + timeout, of the decided ones (stale and no-tests are left out). "before"
    counts only kills by tests whose path does not contain ``new``; "after" counts every kill."""
    head = f"{'area':<11} {'mutants':>7} {'decided':>7} {'before':>14} {'after':>14} {'survived':>8} {'stale':>5}"
    lines = [head]
    for area in (*AREAS, "all"):
        mine = [(s, who) for m, s, who in rows if area == "all" or m.area == area]
        if not mine:
            continue
        decided = [(s, who) for s, who in mine if s in ("killed", "timeout", "survived")]
        after = sum(s in ("killed", "timeout") for s, _ in decided)
        before = sum(s in ("killed", "timeout") and new not in who for s, who in decided)
        n = len(decided)

        def pct(k: int, n: int = n) -> str:
            return f"{k:>3} ({100.0 * k / n:5.1f}%)" if n else "   -"

        lines.append(f"{area:<11} {len(mine):>7} {n:>7} {pct(before):>14} {pct(after):>14} {n - after:>8} "
                     f"{len(mine) - n:>5}")
    return "\n".join(lines)


def changed_files(rev: str) -> set[str]:
    """Files changed between ``rev`` and the working tree (committed or not)."""
    out = subprocess.run(["git", "diff", "--name-only", rev], cwd=ROOT, capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def select(corpus: list[Mutant], args: argparse.Namespace) -> list[Mutant]:
    chosen = corpus
    if args.area:
        chosen = [m for m in chosen if m.area in args.area]
    if args.ids:
        chosen = [m for m in chosen if m.id in args.ids]
    if args.files:
        chosen = [m for m in chosen if m.file in args.files]
    if args.changed:  # the mutant's file changed, or one of the tests that judge it
        changed = changed_files(args.changed)
        chosen = [m for m in chosen if m.file in changed or any(t.split("::")[0] in changed for t in m.tests)]
    for prior in args.skip_killed or []:
        lines = Path(prior).read_text(encoding="utf-8").splitlines()
        killed = {ln.split()[2] for ln in lines if len(ln.split()) >= 3 and ln.split()[1] in ("killed", "timeout")}
        chosen = [m for m in chosen if m.id not in killed]
    if args.order:
        rank = {a: i for i, a in enumerate(args.order)}
        chosen = sorted(chosen, key=lambda m: rank.get(m.area, len(rank)))
    if args.tests:
        chosen = [Mutant(m.id, m.file, m.area, m.original, m.replacement, m.breaks, tuple(args.tests)) for m in chosen]
    if args.rerun:
        lines = Path(args.rerun).read_text(encoding="utf-8").splitlines()
        again = {ln.split()[2] for ln in lines if len(ln.split()) >= 3 and ln.split()[1] == "survived"}
        chosen = [m for m in chosen if m.id in again]
    return chosen


def run_corpus(args: argparse.Namespace) -> int:
    corpus = load_corpus(Path(args.corpus), Path(args.map) if args.map else None)
    chosen = select(corpus, args)
    if args.list or args.check:
        bad = 0
        for k, m in enumerate(chosen, 1):
            text = (ROOT / m.file).read_text(encoding="utf-8") if (ROOT / m.file).exists() else ""
            ok = apply(m, text) is not None
            bad += not ok
            status = ("listed" if ok else "stale") if args.list else ("ok" if ok else "stale")
            print(f"{k:3d}/{len(chosen)} {status:8s} {m.id} {m.area} {m.file} -- {m.breaks}")
        print(f"{len(chosen)} mutants, {bad} stale")
        return 1 if args.check and bad else 0
    log = open(args.log, "a", encoding="utf-8") if args.log else None  # noqa: SIM115 - closed below
    work: queue.Queue[tuple[int, Mutant]] = queue.Queue()
    for k, m in enumerate(chosen, 1):
        work.put((k, m))
    rows: list[tuple[Mutant, str, str]] = []
    lock = threading.Lock()
    base = Path(tempfile.mkdtemp(prefix="robokit-mutation-"))

    def worker(n: int) -> None:
        tree = snapshot(base / f"w{n}", args.rev)
        while True:
            try:
                k, m = work.get_nowait()
            except queue.Empty:
                return
            if args.sync:  # files finished while the run goes on join it (copy only ones that pass unmutated)
                for src in Path(args.sync).rglob("*.py"):
                    dest = tree / src.relative_to(args.sync)
                    dest.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(src, dest)
            status, took, tail = run_mutant(tree, m, args.timeout, args.then_all and not args.grouped, tuple(args.tier))
            who = tail if status in ("killed", "timeout") else ""
            line = f"{k:3d}/{len(chosen)} {status:8s} {m.id} {m.area} {m.file} {took:6.1f}s [{who}] -- {m.breaks}"
            with lock:
                rows.append((m, status, who))
                print(line, flush=True)
                if log is not None:
                    log.write(line + "\n")
                    log.flush()

    try:
        threads = [threading.Thread(target=worker, args=(n,), daemon=True) for n in range(args.workers)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        if args.then_all and args.grouped:
            missed = [m for m, status, _ in rows if status in ("survived", "no-tests")]
            if missed:
                start = time.monotonic()
                caught = whole_tier_grouped(snapshot(base / "tier", args.rev), missed, args.timeout, tuple(args.tier))
                took = time.monotonic() - start
                numbers = {m.id: k for k, m in enumerate(chosen, 1)}
                for m in missed:
                    status, who = ("killed", f"{caught[m.id]} (whole tier)") if m.id in caught else ("survived", "")
                    rows = [(m, status, who) if r[0].id == m.id else r for r in rows]
                    line = (f"{numbers[m.id]:3d}/{len(chosen)} {status:8s} {m.id} {m.area} {m.file} {took:6.1f}s "
                            f"[{who}] -- {m.breaks}")
                    print(line, flush=True)
                    if log is not None:
                        log.write(line + "\n")
                        log.flush()
    finally:
        shutil.rmtree(base, ignore_errors=True)
    done = {m.id for m, _, _ in rows}
    for prior in args.include or []:
        by_id = {m.id: m for m in corpus}
        for ln in Path(prior).read_text(encoding="utf-8").splitlines():
            parts = ln.split()
            if len(parts) >= 3 and parts[2] in by_id and parts[2] not in done and parts[1] in STATUSES:
                who = ln.split("[", 1)[1].split("]", 1)[0] if "[" in ln and parts[1] != "survived" else ""
                rows.append((by_id[parts[2]], parts[1], who))
                done.add(parts[2])
    report = table(rows)
    print(report)
    if log is not None:
        log.write(report + "\n")
        log.close()
    return 0


# ---------------------------------------------------------------------------------------------------- AST sampler
SWAP_CMP = {ast.Lt: ast.LtE, ast.LtE: ast.Lt, ast.Gt: ast.GtE, ast.GtE: ast.Gt, ast.Eq: ast.NotEq,
            ast.NotEq: ast.Eq, ast.In: ast.NotIn, ast.NotIn: ast.In, ast.Is: ast.IsNot, ast.IsNot: ast.Is}


@dataclass(frozen=True)
class AstMutant:
    """One mechanical change: the file, the line, what it does, and the site's index among the file's sites."""

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


def _apply_ast(node: ast.AST, what: str) -> ast.AST:
    """The node with the change ``what`` applied (the replacement node for its parent)."""
    kind, change = what.split(":", 1)
    if kind.startswith("cmp"):
        assert isinstance(node, ast.Compare)
        i = int(kind[3:])
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


def ast_mutants(file: str) -> list[AstMutant]:
    tree = ast.parse((ROOT / file).read_text(encoding="utf-8"))
    return [AstMutant(file, getattr(node, "lineno", 0), what, i) for i, (node, what) in enumerate(_sites(tree))]


def ast_mutated_source(m: AstMutant, text: str) -> str:
    tree = ast.parse(text)
    node, what = list(_sites(tree))[m.site]
    assert what == m.what
    replacement = _apply_ast(node, what)
    if replacement is not node:
        for parent in ast.walk(tree):
            for fld, value in ast.iter_fields(parent):
                if value is node:
                    setattr(parent, fld, replacement)
                elif isinstance(value, list):
                    for k, item in enumerate(value):
                        if item is node:
                            value[k] = replacement
    return ast.unparse(ast.fix_missing_locations(copy.deepcopy(tree)))


def run_ast(args: argparse.Namespace) -> int:
    corpus = load_corpus(Path(args.corpus))
    tests_of = {m.file: m.tests for m in corpus}
    files = args.files or sorted(tests_of)
    rng = random.Random(args.seed)
    sample: list[AstMutant] = []
    for file in files:
        found = ast_mutants(file)
        sample.extend(sorted(rng.sample(found, min(args.per_file, len(found))), key=lambda m: m.site))
    if args.list:
        for k, am in enumerate(sample, 1):
            print(f"{k:3d}/{len(sample)} listed   {am.file}:{am.line} {am.what}")
        return 0
    base = Path(tempfile.mkdtemp(prefix="robokit-mutation-"))
    caught = decided = 0
    try:
        tree = snapshot(base / "w0", args.rev)
        for k, am in enumerate(sample, 1):
            path = tree / am.file
            original = path.read_text(encoding="utf-8")
            try:
                path.write_text(ast_mutated_source(am, original), encoding="utf-8")
                status, took, _ = run_tests(tree, tests_of.get(am.file, ()), args.timeout)
            finally:
                path.write_text(original, encoding="utf-8")
            caught += status in ("killed", "timeout")
            decided += status in ("killed", "timeout", "survived")
            print(f"{k:3d}/{len(sample)} {status:8s} {am.file}:{am.line} {am.what} {took:6.1f}s", flush=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    print(f"caught {caught} of {decided} = {100.0 * caught / max(decided, 1):.0f} %")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--corpus", default=str(CORPUS))
    parser.add_argument("--map", help="read the file -> tests map from this toml (e.g. the corpus) for a sample "
                        "written without one; files it lacks get the tests naming their module")
    parser.add_argument("--then-all", action="store_true",
                        help="a mutant its file's tests miss then runs against the whole default tier")
    parser.add_argument("--grouped", action="store_true",
                        help="with --then-all: the mutants the files' tests miss share the whole tier's runs (all "
                        "planted at once, each failing test traced to the mutant that fails it alone)")
    parser.add_argument("--tier", nargs="*", default=["tests"],
                        help="what --then-all runs for a mutant its file's tests miss (default: tests, the whole "
                        "default tier)")
    parser.add_argument("--area", nargs="*", choices=AREAS, help="only these areas")
    parser.add_argument("--ids", nargs="*", help="only these mutant ids")
    parser.add_argument("--files", nargs="*", help="only mutants of these files (with --ast: the files to sample)")
    parser.add_argument("--changed", metavar="REV", help="only mutants whose file or mapped tests changed since REV")
    parser.add_argument("--rev", help="score REV's tree instead of the working tree")
    parser.add_argument("--workers", type=int, default=1, help="mutants run side by side (each its own copy)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per mutant's test run")
    parser.add_argument("--log", help="append one line per mutant (and the table) to this file")
    parser.add_argument("--skip-killed", nargs="*", metavar="LOG", help="leave out mutants these logs say were caught")
    parser.add_argument("--sync", metavar="DIR",
                        help="before each mutant, copy DIR/**/*.py into the copy (DIR mirrors the repository)")
    parser.add_argument("--order", nargs="*", choices=AREAS, help="run these areas first, in this order")
    parser.add_argument("--include", nargs="*", metavar="LOG", help="count these logs' results for mutants not run now")
    parser.add_argument("--rerun", metavar="LOG", help="only the mutants a previous log says survived")
    parser.add_argument("--tests", nargs="*", help="run these tests instead of the corpus' map (a quick check)")
    parser.add_argument("--list", action="store_true", help="list the selected mutants, run nothing")
    parser.add_argument("--check", action="store_true", help="exit 1 if a selected mutant's snippet is stale")
    parser.add_argument("--ast", action="store_true", help="sample mechanical AST mutants instead of the corpus")
    parser.add_argument("--per-file", type=int, default=5, help="--ast: mutants sampled per file")
    parser.add_argument("--seed", type=int, default=1, help="--ast: sampling seed")
    args = parser.parse_args()
    return run_ast(args) if args.ast else run_corpus(args)


if __name__ == "__main__":
    sys.exit(main())
